#include "paintlab/fitting/axf_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "synthetic.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using test::NearRel;

// A metallic car paint with a hue shift: chi = (1 + d, 1, 1 - d) with d growing with
// theta_ibar, so the mean of R, G, B is exactly the achromatic model.
brdf::AxfCarPaintParams truth_paint() {
  brdf::AxfCarPaintParams p;
  p.ior = 1.55;
  p.diffuse = 0.05;
  p.lobes = {{0.06, 0.30, 0.85}, {0.04, 0.12, 0.55}};
  p.chi.theta_h_samples = 4;
  p.chi.theta_i_samples = 4;
  p.chi.rgb.clear();
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const double d = 0.05 + 0.06 * b + 0.02 * a;
      p.chi.rgb.push_back(brdf::Rgb(1 + d, 1, 1 - d));
    }
  return p;
}

void print_fit(const char* what, const AxfFit& f) {
  std::printf("%s: ior %.4f (+-%.2g) diffuse %.4f", what, f.params.ior, f.stddev.ior, f.params.diffuse);
  for (std::size_t k = 0; k < f.params.lobes.size(); ++k)
    std::printf(" | s %.4f spread %.4f (+-%.2g) f0 %.3f", f.params.lobes[k].coefficient, f.params.lobes[k].spread,
                f.stddev.lobes[k].spread, f.params.lobes[k].f0);
  std::printf("\n  achromatic log-RMS %.4f, model log-RMS %.4f (floor %.4f) peak %.4f glossy %.4f diffuse %.4f; chi %d "
              "measured + %d filled texels; %d iterations, %.2f s\n",
              f.achromatic.total.log_rms, f.residual.total.log_rms, f.residual.total.noise_floor,
              f.residual.regions[0].log_rms, f.residual.regions[1].log_rms, f.residual.regions[2].log_rms,
              f.chi.measured_texels, f.chi.filled_texels, f.summary.iterations, f.summary.time_s);
}

// F0 is held fixed (it cannot be measured through a clear coat, see axf_fit.h), so the
// coefficient is compared as s * F0, what the lobe reflects.
void expect_recovered(const brdf::AxfCarPaintParams& t, const AxfFit& f, double coef_tol, double spread_tol,
                      double ior_tol) {
  EXPECT_THAT(f.params.ior, NearRel(t.ior, ior_tol));
  EXPECT_THAT(f.params.diffuse, NearRel(t.diffuse, coef_tol));
  ASSERT_EQ(f.params.lobes.size(), t.lobes.size());
  for (std::size_t k = 0; k < t.lobes.size(); ++k) {
    EXPECT_THAT(f.params.lobes[k].coefficient * f.params.lobes[k].f0,
                NearRel(t.lobes[k].coefficient * t.lobes[k].f0, coef_tol))
        << "lobe " << k;
    EXPECT_THAT(f.params.lobes[k].spread, NearRel(t.lobes[k].spread, spread_tol)) << "lobe " << k;
  }
}

// Small fits for unit tests: two lobes, fewer starts on a smaller subsample.
AxfFitOptions quick_options() { return test_support::quick_fit<AxfFitOptions>(2); }

TEST(AxfFit, RecoversTheAchromaticLobesAndTheColourTableOfATabulatedPaint) {
  const brdf::AxfCarPaintParams truth = truth_paint();
  // One bin in 8 of the table (about 140 000 bins).
  const FitData data = prepare_fit_data(test_support::tabulate_sparse(brdf::AxfCarPaint(truth), 8));
  AxfFitOptions opt = quick_options();
  opt.covariance = false;
  const AxfFit fit = fit_axf_carpaint(data, opt);
  print_fit("tabulated axf", fit);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit, 0.01, 0.01, 0.01);
  EXPECT_LT(fit.achromatic.total.log_rms, 1e-3);
  // The colour table: the truth's hue shift, within the smoothing of the fitted table.
  EXPECT_LT(fit.residual.total.log_rms, 0.01);
  EXPECT_GT(fit.chi.measured_texels, 0);
  EXPECT_EQ(fit.chi.measured_texels + fit.chi.filled_texels, 32 * 32);
  // Lobes broadest first.
  EXPECT_GT(fit.params.lobes[0].spread, fit.params.lobes[1].spread);
  // The fit reads back as a paint.
  const brdf::PaintSpec spec = brdf::paint_from_json(fit.to_json("axf-test"), "fit");
  ASSERT_NE(spec.axf_carpaint(), nullptr);
  EXPECT_EQ(spec.axf_carpaint()->chi.rgb.size(), 32u * 32u);
}

// The achromatic stage takes the Cook-Torrance fit's delta correction (fit_data.h): exact
// values whose samples spread by 0.4 over 4 samples a bin give a level e^0.05 above them.
TEST(AxfFit, TheDeltaCorrectionTakesTheSamplesSpread) {
  const brdf::AxfCarPaintParams truth = truth_paint();
  // One bin in 64 (about 18 000 bins): the fit cannot follow the peak's 5 % step exactly, so
  // it iterates; under the sanitizers this must stay well inside the test's time limit.
  brdf::MerlTable table = test_support::tabulate_sparse(brdf::AxfCarPaint(truth), 64);
  const std::vector<float> noise = test_support::with_sample_spread(table, 4, 0.4, 1e-6);
  FitDataOptions o;
  o.min_samples = 1;
  AxfFitOptions opt = quick_options();
  opt.covariance = false;
  opt.max_iterations = 30;
  const AxfFit fit = fit_axf_carpaint(prepare_fit_data(table, o, &noise), opt);
  EXPECT_THAT(fit.params.diffuse, NearRel(truth.diffuse * std::exp(0.05), 0.01));
  o.delta_correction = false;
  const AxfFit plain = fit_axf_carpaint(prepare_fit_data(table, o, &noise), opt);
  EXPECT_THAT(plain.params.diffuse, NearRel(truth.diffuse, 0.01));
}

TEST(AxfFit, FitsNoisyBinnedSamplesWithinTheNoise) {
  const brdf::AxfCarPaintParams truth = truth_paint();
  const BinnedTable binned = test_support::binned_sweep(brdf::AxfCarPaint(truth), 100, 0.02, test::seed(), 2.0);
  const FitData data = prepare_fit_data(binned.table, {}, &binned.noise_variance);
  const AxfFitOptions opt = quick_options();
  const AxfFit fit = fit_axf_carpaint(data, opt);
  print_fit("binned axf, 2 % noise", fit);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit, 0.03, 0.02, 0.02);
  EXPECT_TRUE(fit.summary.covariance_ok) << fit.summary.covariance_message;
  EXPECT_LT(fit.achromatic.total.log_rms, 1.5 * fit.achromatic.total.noise_floor);
  EXPECT_LT(fit.residual.total.log_rms, 1.5 * fit.residual.total.noise_floor);
}

TEST(AxfFit, OptionsAndBadInput) {
  AxfFitOptions opt;
  opt.chi_theta_h = 1;
  EXPECT_THROW(opt.check(), OptionError);
  opt = {};
  opt.ior_start = 3.5;
  EXPECT_THROW(opt.check(), OptionError);
  brdf::MerlTable few;
  for (std::size_t b = 0; b < 5; ++b) few.set_value(200000 + b, brdf::Rgb(0.1, 0.1, 0.1), brdf::BinState::Measured);
  EXPECT_THROW(fit_axf_carpaint(prepare_fit_data(few)), DataError);
}

}  // namespace
}  // namespace paintlab::fit
