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
  sets_fields(sub->add_option("--blur-px", a.blur_px,
                              "Lens blur to undo (Gaussian sigma, pixels; -1: the calibration's highlight blur, "
                              "light.json; 0: none): sharpens the clear coat's highlight and the pixels it spills "
                              "into, to first order (docs/fitting.md \"Lens blur and the noise floor\")"),
              {"ExtractionOptions::blur_sigma_px"})
      ->capture_default_str();
  sets_fields(sub->add_option("--max-blur-correction", a.max_blur_correction,
                              "Skip a pixel whose blur correction is more than this fraction of its value (beyond "
                              "its noise): the first-order correction no longer holds there"),
              {"ExtractionOptions::max_blur_correction"})
      ->capture_default_str();
  sub->add_option("--too-sharp", a.too_sharp,
                  "Pixels whose blur correction would not hold (--max-blur-correction): keep them as measured, or "
                  "skip them (paints without sparkle: the clear coat's highlight no longer widens; never with flakes, "
                  "whose glints are part of the paint's average)")
      ->check(CLI::IsMember({"keep", "skip"}))
      ->capture_default_str();
  sets_fields(sub->add_option("--valid-margin-px", a.valid_margin_px,
                              "Use a pixel only when every pixel this close is valid in the HDR image (next to "
                              "pixels below the noise floor only the pixels noise lifted over it are valid: a "
                              "bright bias at the terminator; next to saturated ones, their spill)"),
              {"ExtractionOptions::valid_margin_px"})
      ->capture_default_str();
  sub->add_option("--variance", a.variance,
                  "Sample variance: hdr (the HDR merge's var.* channels) or local (second differences with the "
                  "neighbouring pixels: pixel noise and flake sparkle)")
      ->capture_default_str();
  sub->add_option("--estimator", a.estimator, "Per-bin estimator: mean or median-of-means")->capture_default_str();
}

void add_cfa_sites_option(CLI::App* sub, ExtractArgs& a) {
  a.cfa_sites = "auto";
  sub->add_option("--cfa-sites", a.cfa_sites,
                  "Bayer cameras: fit every colour at the pixels whose filter measured it (camera RGB, then kd and ks "
                  "mapped to the session's colour space), so no demosaiced value reaches the fit and a highlight a "
                  "few pixels across keeps its width. auto: whenever the session allows it (a Bayer camera, bilinear "
                  "demosaicing, the 3x3 matrix colour calibration, cook-torrance, not --variance local); on: or fail "
                  "saying why; off: fit the demosaiced image (docs/fitting.md \"Fitting a Bayer camera at its sites\")")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
}

// The extraction and binning options the flags give (checked by fit::bin_session).
fit::SessionBinOptions bin_options(const ExtractArgs& a) {
  fit::SessionBinOptions o;
  o.extraction.margin_px = a.margin_px;
  o.extraction.blur_sigma_px = a.blur_px;
  o.extraction.valid_margin_px = a.valid_margin_px;
  o.extraction.max_blur_correction = a.max_blur_correction;
  o.extraction.skip_too_sharp = a.too_sharp == "skip";
  o.extraction.variance = fit::variance_model_from_string(a.variance, "--variance");
  o.sites = fit::site_fit_from_string(a.cfa_sites, "--cfa-sites");
  o.extraction.threads = a.threads;
  o.binning.estimator = fit::bin_estimator_from_string(a.estimator, "--estimator");
  o.binning.threads = a.threads;
  if (!a.calib.empty()) o.calib_dir = a.calib;
  return o;
}

}  // namespace paintlab::app
