#include "paintlab/fitting/ct_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/pipeline.h"
#include "synthetic.h"
#include "paintlab/core/log.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using test::NearRel;

using test_support::blue_params;
using test_support::silver_params;

void print_fit(const char* what, const CookTorranceFit& fit) {
  const auto& p = fit.params;
  std::printf("%s: kd %.4f %.4f %.4f", what, p.kd[0], p.kd[1], p.kd[2]);
  for (std::size_t l = 0; l < p.lobes.size(); ++l)
    std::printf(" | ks %.4f %.4f %.4f m %.4f (+-%.2g) r %.3f (+-%.2g)", p.lobes[l].ks[0], p.lobes[l].ks[1],
                p.lobes[l].ks[2], p.lobes[l].m, fit.stddev.lobes[l].m, p.lobes[l].r, fit.stddev.lobes[l].r);
  std::printf("\n  log-RMS %.4f (floor %.4f) peak %.4f glossy %.4f diffuse %.4f; %d iterations, %zu blocks, %zu residuals, %.2f s, converged %d\n",
              fit.residual.total.log_rms, fit.residual.total.noise_floor, fit.residual.regions[0].log_rms,
              fit.residual.regions[1].log_rms, fit.residual.regions[2].log_rms, fit.summary.iterations,
              fit.summary.residual_blocks, fit.summary.residuals, fit.summary.time_s, fit.summary.converged);
}

// Every parameter within the tolerances: kd and ks 3 %, m 2 %, r 5 %.
void expect_recovered(const brdf::CookTorranceParams& truth, const brdf::CookTorranceParams& fit, double kd_tol = 0.03,
                      double ks_tol = 0.03, double m_tol = 0.02, double r_tol = 0.05) {
  ASSERT_EQ(fit.lobes.size(), truth.lobes.size());
  for (int c = 0; c < 3; ++c) EXPECT_THAT(fit.kd[c], NearRel(truth.kd[c], kd_tol)) << "kd channel " << c;
  for (std::size_t l = 0; l < truth.lobes.size(); ++l) {
    for (int c = 0; c < 3; ++c)
      EXPECT_THAT(fit.lobes[l].ks[c], NearRel(truth.lobes[l].ks[c], ks_tol)) << "lobe " << l << " ks channel " << c;
    EXPECT_THAT(fit.lobes[l].m, NearRel(truth.lobes[l].m, m_tol)) << "lobe " << l << " m";
    EXPECT_THAT(fit.lobes[l].r, NearRel(truth.lobes[l].r, r_tol)) << "lobe " << l << " r";
  }
}

// Unit tests keep the fits small (tens of thousands of bins, fewer starts): the full-table
// fit is bench/fitting's BM_FitCookTorranceFullTable, the whole-pipeline accuracy is
// tests/integration/fitting/sim_pipeline_test.cpp.
CtFitOptions quick_options(int lobes) { return test_support::quick_fit<CtFitOptions>(lobes); }

TEST(CookTorranceFit, RecoversThreeLobesFromATabulatedPaintExactly) {
  const brdf::CookTorranceParams truth = silver_params();
  // One bin in 16 of the table (about 70 000 bins, every theta_h row).
  const brdf::MerlTable table = test_support::tabulate_sparse(brdf::CookTorrance(truth.kd, truth.lobes), 16);
  const FitData data = prepare_fit_data(table);
  EXPECT_FALSE(data.has_statistics);
  CtFitOptions opt = quick_options(3);
  opt.covariance = false;
  const CookTorranceFit fit = fit_cook_torrance(data, opt);
  print_fit("tabulated silver", fit);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit.params, 1e-3, 1e-3, 1e-3, 1e-3);
  EXPECT_LT(fit.residual.total.log_rms, 1e-4);
}

TEST(CookTorranceFit, RecoversThreeLobesFromNoisyBinnedSamples) {
  init_logging(1);
  const brdf::CookTorranceParams truth = silver_params();
  const brdf::CookTorrance paint(truth.kd, truth.lobes);
  // A 100-pixel sphere every 2 degrees: about 350 000 samples.
  const BinnedTable binned = test_support::binned_sweep(paint, 100, 0.02, test::seed(), 2.0);
  const FitData data = prepare_fit_data(binned.table, {}, &binned.noise_variance);
  EXPECT_TRUE(data.has_statistics);
  EXPECT_EQ(data.noise_source, NoiseSource::SampleNoise);
  const CookTorranceFit fit = fit_cook_torrance(data, quick_options(3));
  print_fit("binned silver, 2 % noise", fit);
  {
    const ResidualReport truth_res = residual_report(data, evaluate_cook_torrance(data, truth));
    double pix = 0;
    std::size_t n = 0;
    for (const FitBin& b : data.bins) {
      const brdf::Rgb nv = binned.noise(b.bin);
      for (int c = 0; c < 3; ++c) {
        pix += nv[c] / (b.value[c] * b.value[c]) / binned.table.count(b.bin);
        ++n;
      }
    }
    std::printf("truth residual log-RMS %.4f (peak %.4f glossy %.4f diffuse %.4f), pixel-noise floor %.4f\n",
                truth_res.total.log_rms, truth_res.regions[0].log_rms, truth_res.regions[1].log_rms,
                truth_res.regions[2].log_rms, std::sqrt(pix / n));
  }
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit.params);
  EXPECT_LT(fit.residual.total.log_rms, 1.5 * fit.residual.total.noise_floor);
  EXPECT_TRUE(fit.summary.covariance_ok) << fit.summary.covariance_message;
}

TEST(CookTorranceFit, RecoversTwoLobes) {
  const brdf::CookTorranceParams truth = blue_params();
  const brdf::CookTorrance paint(truth.kd, truth.lobes);
  const BinnedTable binned = test_support::binned_sweep(paint, 100, 0.02, test::seed(), 2.0);
  const CtFitOptions opt = quick_options(2);
  const CookTorranceFit fit = fit_cook_torrance(prepare_fit_data(binned.table, {}, &binned.noise_variance), opt);
  print_fit("binned blue, 2 % noise", fit);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit.params);
}

// A fit at the filter-array sites (fit_data.h combine_site_data, ct_fit.h transform_colours):
// three tables of a paint in a camera's RGB, each standing for one colour's sites, fitted
// together with channel c taken from table c alone, and mapped back to sRGB by the camera's
// matrix, recover the sRGB paint; a matrix that takes a colour out of the gamut clips it to 0
// and says so.
TEST(CookTorranceFit, AFitAtTheSitesInCameraRgbIsMappedBackToThePaint) {
  const brdf::CookTorranceParams truth = blue_params();
  Eigen::Matrix3d to_srgb;  // camera RGB -> sRGB, a camera with some crosstalk
  to_srgb << 1.25, -0.15, -0.10, -0.08, 1.18, -0.10, 0.02, -0.22, 1.20;
  const Eigen::Matrix3d to_camera = to_srgb.inverse();
  brdf::CookTorranceParams camera = truth;
  camera.kd = (to_camera * truth.kd.matrix()).array();
  for (brdf::CtLobe& l : camera.lobes) l.ks = (to_camera * l.ks.matrix()).array();
  ASSERT_TRUE((camera.kd > 0).all());
  const brdf::CookTorrance paint(camera.kd, camera.lobes);
  std::array<FitData, 3> per_site;
  std::size_t bins = 0;
  for (std::size_t c = 0; c < 3; ++c) {
    const BinnedTable t = test_support::binned_sweep(paint, 80, 0.02, test::seed() + c, 2.0);
    per_site[c] = prepare_fit_data(t.table, {}, &t.noise_variance);
    bins += per_site[c].bins.size();
  }
  const FitData data = combine_site_data(per_site);
  EXPECT_EQ(data.bins.size(), bins);
  EXPECT_EQ(data.residuals, bins);  // one channel a point
  for (const FitBin& b : data.bins) {
    const int used = (b.inv_sigma[0] != 0.0) + (b.inv_sigma[1] != 0.0) + (b.inv_sigma[2] != 0.0);
    ASSERT_EQ(used, 1);
  }
  const CookTorranceFit fit = fit_cook_torrance(data, quick_options(2));
  print_fit("blue at the sites, camera RGB", fit);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(camera, fit.params);
  int clipped = -1;
  const CookTorranceFit srgb = transform_colours(fit, to_srgb, &clipped);
  EXPECT_EQ(clipped, 0);
  expect_recovered(truth, srgb.params);
  for (int c = 0; c < 3; ++c) {
    double var = 0;
    for (int j = 0; j < 3; ++j) var += to_srgb(c, j) * to_srgb(c, j) * fit.stddev.kd[j] * fit.stddev.kd[j];
    EXPECT_DOUBLE_EQ(srgb.stddev.kd[c], std::sqrt(var));
  }
  Eigen::Matrix3d out_of_gamut = Eigen::Matrix3d::Identity();
  out_of_gamut(0, 2) = -10.0;  // red loses ten times the blue: negative for the blue paint
  const CookTorranceFit clipped_fit = transform_colours(fit, out_of_gamut, &clipped);
  EXPECT_EQ(clipped_fit.params.kd[0], 0.0);
  EXPECT_GE(clipped, 1);
}

// Linear residuals (fit_data.h): a point's weight comes from its neighbours' samples and
// the pooled spread, not from its own value, so a bin that caught a glint is not weighted
// down for it (log residuals weigh by 1 / value).
TEST(FitData, LinearWeightsDoNotDependOnTheBinsOwnValue) {
  brdf::MerlTable table;
  const int i = 30, j = 20;
  auto fill = [&](double glint) {
    for (int k = 0; k < brdf::kMerlPhiD; ++k) {
      const std::size_t b = brdf::merl_flat_index({i, j, k});
      const double v = k == 90 ? glint : 1.0;
      table.set_value(b, brdf::Rgb(v, v, v), brdf::BinState::Measured);
      // 4 samples, relative per-sample variance 0.04 (20 %).
      table.set_statistics(b, 4, brdf::Rgb(0.04, 0.04, 0.04), brdf::merl_bin_centre(b));
    }
  };
  const std::size_t glint_bin = brdf::merl_flat_index({i, j, 90});
  auto point = [&](const FitData& d) -> const FitBin& {
    for (const FitBin& b : d.bins)
      if (b.bin == glint_bin) return b;
    ADD_FAILURE() << "no fit point for the bin";
    return d.bins.front();
  };
  FitDataOptions o;
  o.residuals = FitResiduals::Linear;
  fill(1.0);
  const FitData plain = prepare_fit_data(table, o);
  EXPECT_TRUE(plain.linear);
  const FitBin& p0 = point(plain);
  // ref = 1 (the neighbours), sigma' = sqrt(0.04 / 4 + 0.01^2).
  EXPECT_THAT(p0.linear_sigma[1], NearRel(std::sqrt(0.01 + 1e-4), 1e-6));
  EXPECT_THAT(p0.linear_weight[1], NearRel(1.0 / std::sqrt(0.01 + 1e-4), 1e-6));
  fill(3.0);  // the bin caught a glint
  const FitData glint = prepare_fit_data(table, o);
  // Only through the spread pooled over the 180 bins of the row (2 %).
  EXPECT_THAT(point(glint).linear_weight[1], NearRel(p0.linear_weight[1], 0.03));
  // Log residuals: the linearised weight inv_sigma / value falls threefold.
  o.residuals = FitResiduals::Log;
  const FitData log_plain = prepare_fit_data(table, o);
  EXPECT_FALSE(log_plain.linear);
  const FitBin& lp = point(log_plain);
  EXPECT_LT(lp.inv_sigma[1] / lp.value[1], 0.4 * point(plain).inv_sigma[1] / point(plain).value[1]);
  EXPECT_EQ(fit_residuals_from_string("linear", "test"), FitResiduals::Linear);
  EXPECT_THROW(fit_residuals_from_string("auto", "test"), DataError);
  o.window_phi_d = 0;
  EXPECT_THROW(o.check(), OptionError);
}

// The delta correction of the log residuals (fit_data.h): outside the peak it takes the
// samples' own spread, pooled as a ratio of sums over the 3x3x3 neighbourhood, when that is
// larger than the pixel noise (a glint the noise does not know about); in the peak, where the
// spread inside a bin is the clear coat's change across it, the noise.
TEST(FitData, DeltaCorrectionTakesTheSamplesSpreadOutsideThePeak) {
  brdf::MerlTable table;
  const double noise = 4e-4;  // per-sample variance of the pixel noise
  std::vector<float> noise_variance(3 * brdf::kMerlBins, static_cast<float>(noise));
  const int glossy = 30, peak = 3, j = 20;  // theta_h about 10 deg and 0.1 deg
  for (int i : {glossy, peak})
    for (int k = 0; k < brdf::kMerlPhiD; ++k) {
      const std::size_t b = brdf::merl_flat_index({i, j, k});
      // 4 samples a bin, all alike but one bin that caught a glint: mean 3, variance 12.
      const bool glint = k == 91;
      const double v = glint ? 3.0 : 1.0, var = glint ? 12.0 : 0.0;
      table.set_value(b, brdf::Rgb(v, v, v), brdf::BinState::Measured);
      table.set_statistics(b, 4, brdf::Rgb(var, var, var), brdf::merl_bin_centre(b));
    }
  FitDataOptions o;
  o.min_samples = 1;
  const FitData data = prepare_fit_data(table, o, &noise_variance);
  auto point = [&](int i, int k) -> const FitBin& {
    const std::size_t bin = brdf::merl_flat_index({i, j, k});
    for (const FitBin& b : data.bins)
      if (b.bin == bin) return b;
    ADD_FAILURE() << "no fit point for bin " << i << ", " << k;
    return data.bins.front();
  };
  // Next to the glint: sum var / sum mean^2 over bins 89, 90, 91 = 12 / 11 (the bins' own
  // ratios would average 0.44), over 4 samples, halved.
  EXPECT_NEAR(point(glossy, 90).target[1], 0.5 * (12.0 / 11.0) / 4.0, 1e-6);
  // Far from it only the noise: rho = 4e-4.
  EXPECT_NEAR(point(glossy, 120).target[1], 0.5 * noise / 4.0, 1e-9);
  // The weights keep the noise everywhere, pooled as before (the glint bin's relative noise
  // is 4e-4 / 9).
  const double pooled_noise = (2.0 * noise + noise / 9.0) / 3.0;
  EXPECT_NEAR(point(glossy, 90).noise_sigma[1], std::sqrt(pooled_noise / 4.0), 1e-7);
  // In the peak the noise even next to the glint.
  EXPECT_NEAR(point(peak, 90).target[1], 0.5 * pooled_noise / 4.0, 1e-9);
  EXPECT_NEAR(point(peak, 120).target[1], 0.5 * noise / 4.0, 1e-9);
  // Off: the plain log.
  o.delta_correction = false;
  const FitData plain = prepare_fit_data(table, o, &noise_variance);
  for (const FitBin& b : plain.bins) EXPECT_DOUBLE_EQ(b.target[1], std::log(b.value[1]));
}

// Pooled points: the correction is the members' spread over the point's samples, the small
// remainder at a row's end that joins the point before it included (its spread was once left
// out, its samples counted).
TEST(FitData, APooledPointsCorrectionHoldsEveryMembersSpread) {
  brdf::MerlTable table;
  std::vector<float> noise_variance(3 * brdf::kMerlBins, 1e-8f);
  const int i = 30, j = 20;  // glossy
  for (int k = 0; k < 5; ++k) {  // 5 bins of 4 samples, relative spread 0.4: 16 + a remainder of 4
    const std::size_t b = brdf::merl_flat_index({i, j, k});
    table.set_value(b, brdf::Rgb(1.0, 1.0, 1.0), brdf::BinState::Measured);
    table.set_statistics(b, 4, brdf::Rgb(0.4, 0.4, 0.4), brdf::merl_bin_centre(b));
  }
  FitDataOptions o;
  o.min_samples = 16;
  const FitData data = prepare_fit_data(table, o, &noise_variance);
  ASSERT_EQ(data.bins.size(), 1u);
  EXPECT_EQ(data.bins[0].count, 20u);
  EXPECT_EQ(data.bins[0].bins, 5u);
  EXPECT_NEAR(data.bins[0].bias_variance[1], 0.4 / 20.0, 1e-9);
  EXPECT_NEAR(data.bins[0].target[1], 0.5 * 0.4 / 20.0, 1e-9);
}

// The correction's point variance is what the points' log values scatter by, when that is more
// than their samples' spread / n (fit_data.h point_scatter): under sparkle the samples of a
// point are not independent (a glint seen again in the same bin), and the same samples
// counted twice must not halve the correction (FitDataOptions::point_scatter,
// `paintlab fit --log-correction scatter`). Points of 8 samples whose spread says 0.01 for
// the variance of the log of their mean, whose log values scatter by 0.04 (or by 0.01).
TEST(FitData, TheCorrectionTakesThePointsScatterWhenTheirSamplesAreNotIndependent) {
  auto table_of = [](double log_sd, std::uint32_t count, double spread) {
    brdf::MerlTable table;
    std::mt19937 rng(test::seed());
    std::normal_distribution<double> z(0.0, log_sd);
    for (int i = 28; i <= 32; ++i)  // theta_h about 10 deg, theta_d about 40 deg: glossy
      for (int j = 18; j <= 22; ++j)
        for (int k = 0; k < brdf::kMerlPhiD; ++k) {
          const std::size_t b = brdf::merl_flat_index({i, j, k});
          const double v = std::exp(z(rng));
          table.set_value(b, brdf::Rgb(v, v, v), brdf::BinState::Measured);
          const double var = spread * v * v;  // per-sample relative variance `spread`
          table.set_statistics(b, count, brdf::Rgb(var, var, var), brdf::merl_bin_centre(b));
        }
    return table;
  };
  const std::vector<float> noise(3 * brdf::kMerlBins, 1e-8f);
  FitDataOptions o;
  o.min_samples = 1;
  o.point_scatter = true;
  auto centre = [](const FitData& d) -> const FitBin& {
    const std::size_t bin = brdf::merl_flat_index({30, 20, 45});
    for (const FitBin& b : d.bins)
      if (b.bin == bin) return b;
    ADD_FAILURE() << "no fit point at the centre";
    return d.bins.front();
  };
  // Dependent samples: the log values scatter 4 x what spread / n says.
  const FitData dependent = prepare_fit_data(table_of(0.2, 8, 0.08), o, &noise);
  EXPECT_THAT(centre(dependent).bias_variance[1], NearRel(0.04, 0.1));
  EXPECT_NEAR(centre(dependent).target[1], std::log(centre(dependent).value[1]) + 0.5 * centre(dependent).bias_variance[1], 1e-12);
  // The same samples counted twice: spread / n halves, the correction does not.
  const FitData twice = prepare_fit_data(table_of(0.2, 16, 0.08), o, &noise);
  ASSERT_EQ(twice.bins.size(), dependent.bins.size());
  for (std::size_t q = 0; q < twice.bins.size(); q += 37)
    EXPECT_THAT(twice.bins[q].target[1], NearRel(dependent.bins[q].target[1], 1e-9)) << q;
  // Independent samples: the log values scatter by spread / n, the correction is spread / n.
  const FitData independent = prepare_fit_data(table_of(0.1, 8, 0.08), o, &noise);
  EXPECT_THAT(centre(independent).bias_variance[1], NearRel(0.01, 0.1));
  EXPECT_GE(centre(independent).bias_variance[1], 0.01 * (1.0 - 1e-6));
  // Off (the default): spread / n.
  o.point_scatter = false;
  const FitData assumed = prepare_fit_data(table_of(0.2, 8, 0.08), o, &noise);
  EXPECT_NEAR(centre(assumed).bias_variance[1], 0.01, 1e-9);
  EXPECT_TRUE(std::isnan(assumed.point_scatter));
  EXPECT_THAT(dependent.point_scatter, NearRel(4.0, 0.1));  // what fit.json's residual reports
}

// The correction reaches the fit: exact values whose samples spread by 0.4 (relative
// variance) over 4 samples a bin are read as logs biased by -0.05, so the fitted level comes
// out e^0.05 above the values (and at them with the correction off).
TEST(CookTorranceFit, TheDeltaCorrectionRaisesTheLevelByHalfTheSpread) {
  const brdf::CookTorranceParams truth = blue_params();
  brdf::MerlTable table = test_support::tabulate_sparse(brdf::CookTorrance(truth.kd, truth.lobes), 32);
  const std::vector<float> noise = test_support::with_sample_spread(table, 4, 0.4, 1e-6);
  FitDataOptions o;
  o.min_samples = 1;
  const CookTorranceFit fit = fit_cook_torrance(prepare_fit_data(table, o, &noise), quick_options(2));
  for (int c = 0; c < 3; ++c) EXPECT_THAT(fit.params.kd[c], NearRel(truth.kd[c] * std::exp(0.05), 0.01)) << c;
  o.delta_correction = false;
  const CookTorranceFit plain = fit_cook_torrance(prepare_fit_data(table, o, &noise), quick_options(2));
  for (int c = 0; c < 3; ++c) EXPECT_THAT(plain.params.kd[c], NearRel(truth.kd[c], 0.01)) << c;
}

// Auto pooling (FitDataOptions::min_samples 0): a table whose glossy samples spread like their
// noise is fitted a point per bin; one whose spread is many times the noise (flake sparkle)
// pools to kSparklePooling samples a point, and the residual report says which.
TEST(FitData, AutoPoolingFollowsTheSparkle) {
  const brdf::CookTorranceParams truth = blue_params();
  const brdf::CookTorrance paint(truth.kd, truth.lobes);
  BinnedTable binned = test_support::binned_sweep(paint, 100, 0.02, test::seed(), 2.0);
  const double plain_excess = sparkle_excess(binned.table, &binned.noise_variance);
  std::printf("sparkle excess without flakes: %.2f\n", plain_excess);
  EXPECT_GT(plain_excess, 0.5);
  EXPECT_LT(plain_excess, 3.0);
  FitDataOptions o;  // min_samples 0: auto
  const FitData plain = prepare_fit_data(binned.table, o, &binned.noise_variance);
  EXPECT_EQ(plain.min_samples, 1u);
  EXPECT_DOUBLE_EQ(plain.sparkle_excess, plain_excess);
  for (const FitBin& b : plain.bins) EXPECT_EQ(b.bins, 1u);
  // The same table with glints: the samples' spread 400 x their noise.
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b)
    if (binned.table.state(b) == brdf::BinState::Measured)
      binned.table.set_statistics(b, binned.table.count(b), 400.0 * binned.table.variance(b), binned.table.mean_coords(b));
  EXPECT_NEAR(sparkle_excess(binned.table, &binned.noise_variance), 400.0 * plain_excess, 1e-5 * 400.0 * plain_excess);  // float variances
  const FitData sparkly = prepare_fit_data(binned.table, o, &binned.noise_variance);
  EXPECT_EQ(sparkly.min_samples, kSparklePooling);
  EXPECT_LT(sparkly.bins.size(), plain.bins.size() / 2);
  const ResidualReport rep = residual_report(sparkly, std::vector<double>(3 * sparkly.bins.size(), 0.1));
  EXPECT_EQ(rep.to_json()["min_samples"], kSparklePooling);
  // Without noise variances there is nothing to compare with: a point per bin.
  EXPECT_TRUE(std::isnan(sparkle_excess(binned.table, nullptr)));
  EXPECT_EQ(prepare_fit_data(binned.table, o).min_samples, 1u);
  // An explicit count is used as it is.
  o.min_samples = 1;
  EXPECT_EQ(prepare_fit_data(binned.table, o, &binned.noise_variance).min_samples, 1u);

  // Several sessions of a sparkling paint binned together pool to kSparklePoolingSessions
  // (docs/fitting.md "Sparkle"); without sparkle they keep a point per bin.
  o.min_samples = 0;
  o.sessions = 3;
  const FitData sessions = prepare_fit_data(binned.table, o, &binned.noise_variance);
  EXPECT_EQ(sessions.min_samples, kSparklePoolingSessions);
  EXPECT_LT(sessions.bins.size(), sparkly.bins.size() * 3 / 4);  // this sweep's rows hold a few hundred samples
  for (const FitBin& b : sessions.bins) {
    // Every point holds its share (a row's last, smaller group joins the one before it, so a
    // point falls short only where its whole theta_h x theta_d row holds fewer samples).
    if (b.count < kSparklePoolingSessions) {
      const brdf::MerlBin mb = brdf::merl_bin_of_flat(b.bin);
      std::uint32_t row = 0;
      for (int k = 0; k < brdf::kMerlPhiD; ++k) row += binned.table.count(brdf::merl_flat_index({mb.theta_h, mb.theta_d, k}));
      ASSERT_LT(row, 2 * kSparklePoolingSessions) << b.bin;
    }
  }
  EXPECT_EQ(auto_pooling(plain_excess, 3), 1u);
  EXPECT_EQ(auto_pooling(NAN, 3), 1u);
  EXPECT_EQ(auto_pooling(400.0 * plain_excess, 1), kSparklePooling);
  o.sessions = 0;
  EXPECT_THROW(prepare_fit_data(binned.table, o, &binned.noise_variance), OptionError);
}

// fit_table takes the sessions from the fit's "input" (session_binning.h: "kind": "sessions"
// lists them): a sparkling table of two sessions is fitted at kSparklePoolingSessions
// samples a point, of one session or a MERL table at kSparklePooling.
TEST(FitData, AFitOfSeveralSessionsPoolsLargerPoints) {
  const brdf::CookTorranceParams truth = blue_params();
  const brdf::CookTorrance paint(truth.kd, truth.lobes);
  BinnedTable binned = test_support::binned_sweep(paint, 100, 0.02, test::seed(), 2.0);
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b)
    if (binned.table.state(b) == brdf::BinState::Measured)
      binned.table.set_statistics(b, binned.table.count(b), 400.0 * binned.table.variance(b), binned.table.mean_coords(b));
  FitRequest req = FitRequest::with(FitModel::CookTorrance, "blue", {});
  req.cook_torrance = quick_options(2);
  req.cook_torrance.data.min_samples = 0;
  const Json two = {{"kind", "sessions"}, {"sessions", Json::array({Json::object(), Json::object()})}};
  for (const auto& [input, expected] : {std::pair{two, kSparklePoolingSessions},
                                        std::pair{Json{{"kind", "session"}}, kSparklePooling},
                                        std::pair{Json{{"kind", "merl"}}, kSparklePooling}}) {
    SCOPED_TRACE(input.dump());
    const FitOutcome out = fit_table(binned.table, &binned.noise_variance, req, input);
    EXPECT_EQ(out.fit["residual"]["min_samples"], expected);
    EXPECT_THAT(out.report, ::testing::HasSubstr(fmt::format("pooled to {} samples", expected)));
  }
}

TEST(CookTorranceFit, RecoversTwoLobesWithLinearResiduals) {
  const brdf::CookTorranceParams truth = blue_params();
  const brdf::CookTorrance paint(truth.kd, truth.lobes);
  const BinnedTable binned = test_support::binned_sweep(paint, 100, 0.02, test::seed(), 2.0);
  CtFitOptions opt = quick_options(2);
  opt.data.residuals = FitResiduals::Linear;
  const CookTorranceFit fit = fit_cook_torrance(prepare_fit_data(binned.table, opt.data, &binned.noise_variance), opt);
  print_fit("binned blue, 2 % noise, linear residuals", fit);
  EXPECT_EQ(fit.summary.residual_form, "linear");
  EXPECT_TRUE(fit.summary.converged) << fit.summary.termination;
  expect_recovered(truth, fit.params);
}

TEST(CookTorranceFit, BadInputIsRejected) {
  brdf::MerlTable empty;
  EXPECT_THROW(prepare_fit_data(empty), DataError);
  brdf::MerlTable few;
  for (std::size_t b = 0; b < 4; ++b) few.set_value(100000 + b, brdf::Rgb(0.1, 0.1, 0.1), brdf::BinState::Measured);
  const FitData data = prepare_fit_data(few);
  EXPECT_THROW(fit_cook_torrance(data), DataError);  // 12 values, 18 parameters
  CtFitOptions opt;
  opt.lobes = 4;
  EXPECT_THROW(opt.check(), OptionError);
}

}  // namespace
}  // namespace paintlab::fit
