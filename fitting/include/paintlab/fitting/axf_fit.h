#pragma once
// Fit of the AxF-like car paint model (models.md "AxF-like car paint"; brdf/carpaint.h)
// to a binned table (docs/fitting.md "AxF car-paint fit"), in two stages:
//  1. achromatic: the mean of a bin's R, G, B against
//       T(eta) * (a / pi + sum_k s_k ct_lobe(alpha_k, F0_k; ibar, obar))
//     with ibar, obar the directions refracted by the clear coat (index eta) and T the
//     Fresnel transmittances in and out (brdf::coat_geometry, brdf::ct_lobe: the code the
//     model evaluates). Ceres, autodiff over the 2 + 2K parameters (eta included), whitened
//     log residuals at the bins' mean coordinates, a Huber loss, bounds (eta in
//     [ior_min, ior_max], a, s >= 0, alpha in [m_min, 1)), starts from a grid
//     over the spreads with NNLS for a and s plus seeded perturbations; lobes broadest first.
//     F0 is held fixed (AxfFitOptions::f0): inside a coat of index eta no direction is more
//     than asin(1/eta) from the normal, so Schlick's (1 - h.o)^5 stays below (1 -
//     cos(asin(1/eta)))^5 (0.06 % at eta = 1.5) and F0 trades exactly against s: it cannot
//     be measured. fit_f0 = true fits it anyway (its standard deviation then says so);
//  2. colour: chi(theta_hbar, theta_ibar) per texel = weighted mean of measured RGB / the
//     achromatic model of the bins that fall near the texel (bilinear splatting), smoothed
//     by a normalised Gaussian convolution, and filled where no bin fell by the same
//     convolution with a growing kernel. The whole table is filled (also where
//     theta_d > pi/2 - theta_h, which importers have stumbled on), scale 1.
// Standard deviations of the stage-1 parameters from ceres::Covariance.
#include <cstdint>
#include <string>
#include <vector>

#include "paintlab/brdf/carpaint.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/ct_fit.h"
#include "paintlab/fitting/fit_data.h"

namespace paintlab::fit {

struct AxfFitOptions : MultiStartOptions {
  AxfFitOptions() { grid_starts = 3; }
  double ior_min = 1.0, ior_max = 2.5, ior_start = 1.5;
  double f0 = 0.9;                 // F0 of every lobe when not fitted (aluminium flakes), (0, 1)
  bool fit_f0 = false;
  int chi_theta_h = 32;            // colour table samples over theta_hbar, >= 2
  int chi_theta_i = 32;            // and over theta_ibar, >= 2
  double chi_smoothing_texels = 1.0;  // Gaussian sigma of the smoothing, > 0
  void check() const;
};

struct AxfStddev {
  double ior = 0;
  double diffuse = 0;
  std::vector<brdf::AxfLobe> lobes;  // coefficient, spread, f0 hold standard deviations
  Json to_json() const;               // {"ior", "diffuse", "lobes": [{"coefficient", "spread", "f0"}]}
};

struct ChiReport {
  int measured_texels = 0;  // texels with bins splatted into them
  int filled_texels = 0;    // texels filled by the growing kernel
  Json to_json() const;
};

struct AxfFit {
  brdf::AxfCarPaintParams params;  // lobes broadest first
  AxfStddev stddev;
  ResidualReport achromatic;       // stage 1: mean of RGB against the achromatic model
  ResidualReport residual;         // the whole model (chi included) against R, G, B
  ChiReport chi;
  FitSummary summary;              // of stage 1
  // {"name", "model": "axf-carpaint", ...paint keys..., "residual", "achromatic_residual",
  //  "stddev", "chi_table", "summary"}; brdf::paint_from_json reads it back as a paint.
  Json to_json(const std::string& name) const;
};

// Throws DataError when the data cannot determine the parameters. A stage-1 solve that does
// not converge is returned with summary.converged = false.
AxfFit fit_axf_carpaint(const FitData& data, const AxfFitOptions& options = {});

// The model at every fit bin (3 per bin, at the mean coordinates), via brdf::AxfCarPaint.
std::vector<double> evaluate_axf_carpaint(const FitData& data, const brdf::AxfCarPaintParams& params);

}  // namespace paintlab::fit
