#pragma once
// The steps `paintlab fit` and `paintlab bin` chain (docs/fitting.md): a table (binned from
// a session, or read from a MERL .binary) -> fit data -> the chosen model's fit -> the
// fit.json object. Library code: throws DataError on bad input and JobError when the fit
// does not converge (callers then write nothing).
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_fit.h"
#include "paintlab/fitting/ct_fit.h"

namespace paintlab::fit {

enum class FitModel { CookTorrance, AxfCarPaint };
const char* to_string(FitModel m);  // "cook-torrance", "axf-carpaint"
// DataError naming `where` for other names.
FitModel fit_model_from_string(std::string_view s, std::string_view where);

struct FitRequest {
  FitModel model = FitModel::CookTorrance;
  std::string name = "fitted";  // paint name written into fit.json ([a-z0-9._-]+)
  CtFitOptions cook_torrance;
  AxfFitOptions axf_carpaint;
};

struct FitOutcome {
  Json fit;               // the fit.json object (DESIGN.md "fit" + stddev + summary + input)
  std::string report;     // lines for people: parameters, residuals per region, solver figures
};

// Fits the Measured bins of `table` (filled bins are never used). `noise_variance` is
// BinnedTable::noise_variance or null. `input` goes into fit.json as "input". Throws
// JobError ("the cook-torrance fit did not converge ...") when Ceres did not converge.
FitOutcome fit_table(const brdf::MerlTable& table, const std::vector<float>* noise_variance, const FitRequest& request,
                     const Json& input);

// A paint name from free text (a file stem, a sample name): lower case, characters outside
// [a-z0-9._-] become '-', never empty.
std::string paint_name_from(std::string_view text);

}  // namespace paintlab::fit
