#include "extract_options.h"

#include <optional>

#include "cli.h"

#include "paintlab/fitting/binning.h"
#include "paintlab/fitting/extraction.h"

namespace paintlab::app {

void add_extract_options(CLI::App* sub, ExtractArgs& a, bool fits) {
  CLI::Option* threads = sub->add_option("--threads", a.threads, "Worker threads, 0 = all cores")->capture_default_str();
  if (fits) sets_fields(threads, {"ExtractionOptions::threads", "BinningOptions::threads", "CtFitOptions::threads"});
  else sets_fields(threads, {"ExtractionOptions::threads", "BinningOptions::threads"});
  sub->add_option("--calib", a.calib,
                  "Calibration folder (default: the calibration folder of the rig file the session names)");
  sets_fields(sub->add_option("--margin-px", a.margin_px, "Sphere pixels used: at least this far inside the silhouette"),
              {"ExtractionOptions::margin_px"})
      ->capture_default_str();
  sub->add_option("--variance", a.variance,
                  "Sample variance: hdr (the HDR merge's var.* channels) or local (second differences with the "
                  "neighbouring pixels: pixel noise and flake sparkle)")
      ->capture_default_str();
  sub->add_option("--estimator", a.estimator, "Per-bin estimator: mean or median-of-means")->capture_default_str();
}

// The extraction and binning options the flags give (checked by fit::bin_session).
fit::SessionBinOptions bin_options(const ExtractArgs& a) {
  fit::SessionBinOptions o;
  o.extraction.margin_px = a.margin_px;
  o.extraction.variance = fit::variance_model_from_string(a.variance, "--variance");
  o.extraction.threads = a.threads;
  o.binning.estimator = fit::bin_estimator_from_string(a.estimator, "--estimator");
  o.binning.threads = a.threads;
  if (!a.calib.empty()) o.calib_dir = a.calib;
  return o;
}

}  // namespace paintlab::app
