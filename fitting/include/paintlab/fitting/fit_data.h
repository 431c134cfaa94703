#pragma once
// The measured bins of a table prepared for a fit, and the residual statistics every fit
// reports (docs/fitting.md "Fits").
//
// A fit compares log values. Per measured bin b and channel c:
//   y_bc     = log(v_bc) + t2_bc / 2      (delta-method correction: E[log mean] is
//                                          log(truth) - var/(2 v^2) to second order)
//   t2_bc    = max(rho_bc, spread_bc) / n_b outside the peak region, s2_bc in it:
//              spread_bc = sum (n - 1) var / sum (n - 1) mean^2 over the bin's 3x3x3
//              neighbourhood, the samples' own relative scatter, which holds the flakes'
//              sparkle that the pixel-noise variance does not (a ratio of sums: glints are
//              rare, so most bins' own var / mean^2 is near 0); in the peak the spread
//              inside a bin is the clear coat's change across it, not noise
//   s2_bc    = rho_bc / n_b               variance of log(v_bc) from the samples
//   rho_bc   = relative per-sample variance var/v^2 POOLED over the bin's 3x3x3
//              neighbourhood (degrees-of-freedom weighted), so a bin is not weighted by its
//              own luck (with sparkle, a bin that drew few glints has a low mean AND a low
//              variance)
//   sigma_bc = sqrt(s2_bc + floor^2)      floor: relative model/calibration error
// The per-sample variance is the samples' own noise variance when binning had it
// (BinnedTable::noise_variance: extraction's estimate of pixel noise plus sparkle), else
// the spread of the bin's samples, which also holds the BRDF's variation across the bin
// and so overstates the noise near the peak.
// Tables without sample statistics (a MERL file) get sigma = floor everywhere and no
// correction. Only Measured bins are used: filled bins never count as measurements.
// Models are evaluated at the bins' mean coordinates (models.md: centres bias narrow lobes).
//
// Linear residuals (FitResiduals::Linear, opt-in; docs/fitting.md "Sparkle"):
//   r_bc     = (f_bc - v_bc) / (sigma'_bc ref_bc)
//   ref_bc   = mean of the samples of the NEIGHBOURING bins (same theta_h row, theta_d +-1,
//              phi_d within FitDataOptions::window_phi_d bins of the point; twice that where
//              they hold fewer samples than the point), the point's own bins left out: a
//              relative scale that does not know the point's own noise
//   sigma'_bc = sqrt(rho'_bc / n_b + floor^2), rho'_bc = max(rho_bc, the relative spread of
//              the samples pooled over a cell of one theta_h row and ten theta_d rows, else
//              the row, else the rows around it): the per-sample scatter including flake
//              sparkle, which the pixel-noise variance does not know about.
// Why: with flake sparkle the samples of a bin are skewed (rare bright glints whose average
// is the flake lobes), so the log of a bin mean is biased low by more than the delta method
// repairs, and the robust loss on log residuals follows the median, lower still. The mean
// of a bin is unbiased, and so is a least-squares fit of f to it whose weights do not
// depend on the bin's own value. Measured on the simulated rig it recovers the flake lobes'
// level better, but it weighs the peak by the sparkle-inflated spread and can lose the
// clear coat on a small sweep, so log residuals stay the default.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/coverage.h"

namespace paintlab::fit {

// How a fit compares model and data (see above).
enum class FitResiduals {
  Log,     // (log f - y) / sigma
  Linear,  // (f - v) / (sigma' ref)
};
const char* to_string(FitResiduals r);  // "log", "linear"
// DataError naming `where` for other names.
FitResiduals fit_residuals_from_string(std::string_view s, std::string_view where);

// Auto pooling (FitDataOptions::min_samples 0): the samples a fit point pools to when the table
// sparkles, and the sparkle_excess above which it does.
inline constexpr std::uint32_t kSparklePooling = 16;
inline constexpr double kSparkleExcess = 20.0;
// Auto pooling of a sparkling table that holds several sessions binned together (other spheres
// or orientations of one paint, `paintlab fit S1 S2 ...`): fit points of this many samples.
// Why (docs/fitting.md "Sparkle", full demo rig, 2026-12-07): with 16-sample points the fit
// of several flake fields' data puts the medium flake lobe's r 4.6 % below what the best
// estimator of those data gives (mean over five pairs of panels and all five together; the
// level ks r 1.4-4.3 % low), with 256-sample points 1.0 % above it (within 3.1 %; the level
// within 1.3 %): five panels r -4.4 -> -2.0 %, ks +3.2 -> +1.7 %. One panel is left at
// kSparklePooling: its fit is not linear in its one flake field, and at 256 samples it puts r
// 6-14 % above that estimator on each of five panels (at 16: +0.4 % on average).
inline constexpr std::uint32_t kSparklePoolingSessions = 256;
// Above this the fit's report says that a flake lobe's ks / r split is the flakes' draw: few
// flakes a pixel (1450 and 8320 on the 640 x 480 and full demo rigs). Not at 22.5 (the quick
// demo's half-resolution rig, many flakes a pixel) nor 25.6 (the full demo rig's silver
// without flakes: its lobes change within a bin by more than the low noise of that rig).
inline constexpr double kSparkleDrawNote = 100.0;

// How much the samples of the glossy region (theta_h 4-25 deg, outside the clear coat's peak)
// spread beyond their noise: sum over its bins of (n - 1) x sample variance over the same sum
// of the per-sample noise variance, in green. Measured: 0.9-3.3 for the simulated paints
// without flakes (bins wide for a lobe spread more) and 8.0 for the green pearlescent (its
// colour travels within a bin); with the silver metallic's flakes 1450 on the 640 x 480 rig,
// 8320 on the full demo's Bayer rig, 22.5 and 10.6 on the quick demo's half-resolution Bayer
// and filter-wheel rigs (more flakes a pixel, each glint shared). docs/fitting.md "Pooling". NaN without noise variances or bins of 3 samples or more. `channel`: the
// table's channel to look at (a filter-array site table holds its own colour only).
double sparkle_excess(const brdf::MerlTable& table, const std::vector<float>* noise_variance, int channel = 1);

// The pooling auto chooses (FitDataOptions::min_samples 0) for a table of `sessions` sessions
// whose sparkle_excess is `excess`: a point per bin (1) unless the excess is above
// kSparkleExcess, then kSparklePooling for one session and kSparklePoolingSessions for several.
std::uint32_t auto_pooling(double excess, std::uint32_t sessions);

struct FitDataOptions {
  double relative_floor = 0.01;  // floor of sigma (relative error), > 0
  FitResiduals residuals = FitResiduals::Log;
  int window_phi_d = 8;          // Linear: phi_d bins on each side of a point in its reference window, 1..90
  bool delta_correction = true;
  // The correction's point variance at least the scatter of neighbouring points' log values
  // (outside the peak): under sparkle a point's samples are not independent (a glint seen
  // again in the same bin by one pixel in consecutive images), and spread / n understates
  // the variance of its mean. Measured by second differences of the log values along phi_d,
  // pooled over theta_h +-1 and theta_d +-2 rows; never below spread / n (fit_data.cpp).
  // Off by default: it brings the flake lobe's level at low theta_d to the truth (full demo
  // rig, level ks r -2.3..-5.8 -> -1.7..+2.0 % on five panels), but moves its ks / r split (docs/fitting.md "Sparkle").
  bool point_scatter = false;
  std::uint32_t min_count = 1;   // measured bins with fewer samples are left out (tables with counts)
  // Consecutive phi_d bins of one (theta_h, theta_d) row are pooled into one fit point until
  // they hold this many samples together (tables with counts; 1 = every bin on its own).
  // The point's data value is the mean of all its samples, its model value the
  // count-weighted mean of the model at each member bin's mean coordinates, so pooling
  // adds no model error. Why: with flake sparkle single pixels vary by 100 % and more, and
  // the log of a mean over a few samples is biased far beyond what a delta-method
  // correction repairs; the log of a mean over many is not. 0 = auto: kSparklePooling when
  // the table sparkles (sparkle_excess above kSparkleExcess), else 1. Pooling changes how much
  // each region of the table weighs in the fit (a pooled point is one residual), so a paint a
  // model cannot follow (a pearlescent under Cook-Torrance) is fitted a point per bin.
  std::uint32_t min_samples = 0;
  // Sessions binned into the table (independent flake fields of one paint), >= 1: auto pooling
  // of a sparkling table takes kSparklePoolingSessions when more than one (auto_pooling).
  // fit_table and fit_sites (pipeline.h) set it from the fit's "input"; callers of
  // prepare_fit_data set it themselves.
  std::uint32_t sessions = 1;
  void check() const;
};

// What the Cook-Torrance and the AxF car-paint fits share: the multi-start search, the
// solver and the data. CtFitOptions and AxfFitOptions derive from it.
struct MultiStartOptions {
  int lobes = 3;                   // Cook-Torrance lobes, or the car paint's achromatic lobes: 1..3
  int grid_starts = 4;             // best grid points started from, >= 1
  int random_starts = 2;           // seeded perturbations of the best grid point, >= 0
  std::uint64_t seed = 1;          // of the random starts
  int max_iterations = 100;        // of the final solve (starts get a third), >= 1
  std::size_t start_bins = 15000;  // subsample size for the starts (all bins if fewer), >= 100
  double huber_scale = 2.0;        // in sigmas; 0 = plain least squares
  double m_min = 1e-3;             // lower bound of m (or of the spreads), (0, 0.1)
  int threads = 0;                 // 0 = all cores
  bool covariance = true;
  int chunk_bins = 256;            // bins per residual block, >= 1
  FitDataOptions data;
  // OptionError "<owner>::<field>" for the first violated rule.
  void check_shared(const char* owner) const;
};

// A bin inside a fit point: where the model is evaluated and with which weight
// (its share of the point's samples; the weights of a point sum to 1).
struct FitMember {
  Eigen::Vector3d coords = Eigen::Vector3d::Zero();  // mean (theta_h, theta_d, phi_d) of its samples
  brdf::LobeGeometry geometry;                        // cosines there
  double weight = 1.0;
};

// One point of a fit: a measured bin, or a group of neighbouring phi_d bins
// (FitDataOptions::min_samples) whose samples are pooled.
struct FitBin {
  std::uint32_t bin = 0;          // the (first) bin
  std::uint32_t bins = 1;         // bins pooled
  std::uint32_t count = 0;        // samples pooled (0 without statistics)
  Region region = Region::Diffuse;
  Eigen::Vector3d coords = Eigen::Vector3d::Zero();  // mean (theta_h, theta_d, phi_d) of the samples
  std::uint32_t member_begin = 0;                     // into FitData::members
  std::uint32_t member_count = 1;
  std::array<double, 3> value{};                      // v_bc (1/sr)
  std::array<double, 3> target{};                     // y_bc
  std::array<double, 3> inv_sigma{};                  // 1 / sigma_bc; 0 = channel not used (v <= 0)
  std::array<double, 3> noise_sigma{};                // sqrt(s2_bc): the log noise of the value alone
  std::array<double, 3> bias_variance{};              // t2_bc: what the delta correction of y_bc halves
  std::array<double, 3> linear_weight{};              // Linear: 1 / (sigma'_bc ref_bc); 0 = not used
  std::array<double, 3> linear_sigma{};               // Linear: sigma'_bc (relative)
};

enum class NoiseSource { None, SampleSpread, SampleNoise };
const char* to_string(NoiseSource s);  // "none", "sample-spread", "sample-noise"

struct FitData {
  std::vector<FitBin> bins;
  std::vector<FitMember> members;  // of all bins, FitBin::member_begin ..
  std::size_t residuals = 0;     // used (bin, channel) pairs
  bool has_statistics = false;   // counts and variances were available
  NoiseSource noise_source = NoiseSource::None;
  bool linear = false;           // residuals in linear form (FitResiduals::Linear)
  std::uint32_t min_samples = 1; // the pooling used (options.min_samples, or what auto chose)
  double sparkle_excess = NAN;   // of the table (auto pooling), NaN when not measured
  // How much more the glossy points' log values scatter than their samples' spread / n says
  // (the median over the glossy points of the factor the delta correction's t2 took,
  // FitDataOptions::point_scatter; 1 = independent samples). NaN when not applied.
  double point_scatter = NAN;
  FitDataOptions options;
};

// The members of a fit point.
inline const FitMember* members_begin(const FitData& d, const FitBin& b) { return d.members.data() + b.member_begin; }
inline const FitMember* members_end(const FitData& d, const FitBin& b) {
  return d.members.data() + b.member_begin + b.member_count;
}

// A model's value at every fit point, 3 values (R, G, B) a point as the residuals take them:
// `base` plus the weighted sum over the point's members of `member_value(member)` (an Rgb).
template <class MemberValue>
std::vector<double> evaluate_bins(const FitData& data, const brdf::Rgb& base, MemberValue member_value) {
  std::vector<double> out(3 * data.bins.size());
  for (std::size_t q = 0; q < data.bins.size(); ++q) {
    brdf::Rgb f = base;
    for (const FitMember* m = members_begin(data, data.bins[q]); m != members_end(data, data.bins[q]); ++m)
      f += m->weight * member_value(*m);
    for (int c = 0; c < 3; ++c) out[3 * q + c] = f[c];
  }
  return out;
}

// Throws DataError when the table has no usable measured bins ("the table has no
// measured bins with positive values: nothing to fit"). `noise_variance` (3 per bin, the
// mean per-sample noise variance; may be null or empty) replaces the sample spread.
FitData prepare_fit_data(const brdf::MerlTable& table, const FitDataOptions& options = {},
                         const std::vector<float>* noise_variance = nullptr);

// One fit of the three tables of a Bayer session binned at its filter-array sites
// (extraction.h bin_frames_by_site): the points of table c keep channel c alone (the other
// channels' weights are zero), so a model with per-channel kd and ks and shared m and r is
// fitted in camera RGB to every colour's own sites. Each table's points are prepared as
// prepare_fit_data does (their pooling and pooled variances within the table).
FitData combine_site_data(std::array<FitData, 3> per_site);

// Residual statistics of model predictions `model` (3 per fit bin, 1/sr) against the data:
// unweighted log-RMS of log(model) - log(value) over used (bin, channel) pairs, overall
// and per region, and the noise floor (RMS of noise_sigma: what a perfect model would leave).
struct RegionResidual {
  std::size_t bins = 0;
  std::size_t residuals = 0;
  double log_rms = 0;
  double noise_floor = std::numeric_limits<double>::quiet_NaN();  // NaN without statistics
  Json to_json() const;
};
// Measured against fitted along theta_h at one theta_d, the way Günther et al. 2005 judge a
// fit (their Figure 5): the fit points whose mean theta_d lies within kCurveHalfWidthDeg of
// the slice's, grouped by their MERL theta_h bin; per group the mean theta_h, and the mean
// over the points and their used channels of the measured value and of the model's value
// there (so both average over the same phi_d and channels). For `paintlab report`.
struct FitCurve {
  static constexpr double kCurveHalfWidthDeg = 2.5;
  double theta_d_deg = 0;
  std::vector<double> theta_h_deg;
  std::vector<double> measured;  // 1/sr
  std::vector<double> model;     // 1/sr
  std::vector<std::uint32_t> points;
  Json to_json() const;  // {"theta_d_deg", "theta_h_deg": [..], "measured": [..], "model": [..], "points": [..]}
};
// The theta_d of the curves a residual report carries (deg).
inline constexpr std::array<double, 5> kCurveThetaDDeg = {5.0, 15.0, 30.0, 45.0, 60.0};

struct ResidualReport {
  NoiseSource noise_source = NoiseSource::None;  // what the noise floor comes from
  std::uint32_t min_samples = 1;                 // FitData::min_samples
  double sparkle_excess = NAN;                   // FitData::sparkle_excess
  double point_scatter = NAN;                    // FitData::point_scatter
  RegionResidual total;
  std::array<RegionResidual, kRegionCount> regions;
  std::vector<FitCurve> curves;  // at kCurveThetaDDeg, those with at least 3 theta_h groups
  // Where the fit has data in the (theta_h, theta_d) plane: samples per MERL theta_h bin x
  // theta_d bin over every phi_d (a fit point's samples at its mean coordinates; points
  // without statistics count 1), theta_h-major; all zero for an empty fit.
  std::vector<std::uint32_t> coverage;
  // {"log_rms", "bins_used", "residuals", "noise_floor_log_rms", "noise_source", "min_samples",
  //  "sparkle_excess" (null when not measured), "point_scatter" (null when not applied), "regions": {...},
  //  "curves": [...], "coverage": {"theta_h_bins": 90, "theta_d_bins": 90, "cells": [[i, j, samples], ...]}}
  //  (coverage: the non-zero cells only)
  Json to_json() const;
};
ResidualReport residual_report(const FitData& data, const std::vector<double>& model);

}  // namespace paintlab::fit
