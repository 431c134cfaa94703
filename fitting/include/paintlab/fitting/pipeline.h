#pragma once
// The steps `paintlab fit` and `paintlab bin` chain (docs/fitting.md): a table (binned from
// a session, or read from a MERL .binary) -> fit data -> the chosen model's fit -> the
// fit.json object. Library code: throws DataError on bad input. A fit that stops before
// Ceres reports convergence (at its iteration limit, say) is no exception: it is returned
// with its last parameters and FitOutcome::converged = false, and fit.json's "summary"
// says "converged": false with the termination; the commands decide what to print and
// which exit code to give (docs/fitting.md).
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_fit.h"
#include "paintlab/fitting/ct_fit.h"
#include "paintlab/fitting/extraction.h"

namespace paintlab::fit {

enum class FitModel { CookTorrance, AxfCarPaint };
const char* to_string(FitModel m);  // "cook-torrance", "axf-carpaint"
// DataError naming `where` for other names.
FitModel fit_model_from_string(std::string_view s, std::string_view where);

// What the Cook-Torrance and the AxF car-paint fits share: set once, for either model.
struct SharedFitOptions {
  int lobes = 3;                   // Cook-Torrance lobes, or the car paint's achromatic lobes: 1..3
  std::uint64_t seed = 1;          // of the random starts
  int threads = 0;                 // 0 = all cores
  int max_iterations = 100;        // of the final solve
  // FitDataOptions::min_samples: 0 = auto (pooled to kSparklePooling samples when the table
  // sparkles, a point per bin otherwise).
  std::uint32_t min_samples = 0;
};

struct FitRequest {
  FitModel model = FitModel::CookTorrance;
  std::string name = "fitted";  // paint name written into fit.json ([a-z0-9._-]+)
  CtFitOptions cook_torrance;
  AxfFitOptions axf_carpaint;

  // A request for `model` with `shared` set in both models' options (the rest default).
  static FitRequest with(FitModel model, std::string name, const SharedFitOptions& shared);
  // Sets `shared` in both models' options.
  void set_shared(const SharedFitOptions& shared);
  // Checks the chosen model's options (DataError naming the field and the rule).
  void check() const;
};

struct FitOutcome {
  Json fit;               // the fit.json object (DESIGN.md "fit" + stddev + summary + input)
  std::string report;     // lines for people: parameters, residuals per region, solver figures
  bool converged = false; // the final solve terminated with Ceres' CONVERGENCE (= fit["summary"]["converged"])
  // Ceres' termination type and message with the iteration count, e.g. "NO_CONVERGENCE:
  // Maximum number of iterations reached. ... (100 iterations)".
  std::string termination;
};

// Fits the Measured bins of `table` (filled bins are never used). `noise_variance` is
// BinnedTable::noise_variance or null. `input` goes into fit.json as "input". Never throws
// for a fit that did not converge: the outcome says so (converged, termination) and holds
// the last parameters. Throws DataError when the data cannot be fitted and JobError when no
// start gave a usable solution.
FitOutcome fit_table(const brdf::MerlTable& table, const std::vector<float>* noise_variance, const FitRequest& request,
                     const Json& input);

// Fits the Cook-Torrance model to a session binned at its filter-array sites (extraction.h
// ExtractionOptions::cfa_sites): in camera RGB, each channel to its own colour's sites
// (combine_site_data), then kd and ks mapped to the session's colour space by
// `sites.to_colour_space` (transform_colours). The residuals in fit.json are those in camera
// RGB. DataError for the AxF car-paint model (its colour table is fitted in the session's
// colour space).
FitOutcome fit_sites(const SiteTables& sites, const FitRequest& request, const Json& input);

// A paint name from free text (a file stem, a sample name): lower case, characters outside
// [a-z0-9._-] become '-', never empty.
std::string paint_name_from(std::string_view text);

}  // namespace paintlab::fit
