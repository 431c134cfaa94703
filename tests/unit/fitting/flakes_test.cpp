// Flake statistics (fitting/flakes.h): the slice geometry, the octree colour clusters, the
// flakes.json round trip, and extraction on simulated sweeps with and without flakes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;

TEST(FlakeSlices, RefractedHalfAndDifferenceAnglesPickTheBins) {
  // Head on: theta_F = theta_I = 0.
  EXPECT_EQ(flake_slice_of(Vec3::UnitZ(), Vec3::UnitZ(), 1.5, 12, 12), (std::array<int, 2>{0, 0}));
  // The mirror geometry at 60 deg: hbar along the normal, theta_I the refracted angle,
  // asin(sin 60 / 1.5) = 35.26 deg: bin floor(12 x 35.26 / 90) = 4 (without +0.5).
  const double a = deg_to_rad(60.0);
  const Vec3 wi(std::sin(a), 0, std::cos(a)), wo(-std::sin(a), 0, std::cos(a));
  EXPECT_EQ(flake_slice_of(wi, wo, 1.5, 12, 12), (std::array<int, 2>{0, 4}));
  // Without a coat (index 1) the same geometry is 60 deg: bin 8.
  EXPECT_EQ(flake_slice_of(wi, wo, 1.0, 12, 12), (std::array<int, 2>{0, 8}));
  // Light and view together at 40 deg off the normal: theta_F = refracted 40 deg = 25.37 deg
  // (bin 3), theta_I = 0.
  const double b = deg_to_rad(40.0);
  const Vec3 w(std::sin(b), 0, std::cos(b));
  EXPECT_EQ(flake_slice_of(w, w, 1.5, 12, 12), (std::array<int, 2>{3, 0}));
  // A grazing pair stays inside the grid.
  const Vec3 g(0.9999, 0, 0.0141);
  const auto s = flake_slice_of(g, g, 1.0, 12, 12);
  EXPECT_EQ(s[0], 11);
}

// Three well separated groups of colours in CIELAB with known shares.
std::vector<colour::Lab> three_groups(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<colour::Lab> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = u(rng);
    const colour::Lab c = r < 0.5 ? colour::Lab{60, 0, 0} : r < 0.8 ? colour::Lab{80, 30, -20} : colour::Lab{120, -25, 40};
    out.push_back({c.L + g(rng), c.a + g(rng), c.b + g(rng)});
  }
  return out;
}

TEST(FlakeClusters, OctreeKeepsAtMostNClustersThatCoverEveryColour) {
  const std::vector<colour::Lab> colours = three_groups(20000, 3);
  std::vector<FlakeCluster> clusters;
  std::vector<std::uint8_t> cdf;
  cluster_flake_colours(colours, 50, 500, &clusters, &cdf);
  ASSERT_LE(clusters.size(), 50u);
  ASSERT_GE(clusters.size(), 20u);  // the budget is used, not collapsed to a few
  double p = 0;
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    p += clusters[i].probability;
    n += clusters[i].count;
    if (i > 0) {
      EXPECT_LE(clusters[i].probability, clusters[i - 1].probability);  // most likely first
    }
    const FlakeCluster& c = clusters[i];
    EXPECT_LE(c.lo.L, c.mean.L);
    EXPECT_GE(c.hi.L, c.mean.L);
  }
  EXPECT_NEAR(p, 1.0, 1e-12);
  EXPECT_EQ(n, colours.size());
  // Each cluster's cuboid is centred on its mean with the spread of its colours: the three
  // groups (sd 1.5 per axis) give boxes no wider than a group (half-width sqrt(3) sd, with
  // room for a cluster that straddles a few sd), far narrower than the colours' whole box.
  for (const FlakeCluster& c : clusters) {
    EXPECT_NEAR(0.5 * (c.lo.L + c.hi.L), c.mean.L, 1e-9);
    EXPECT_NEAR(0.5 * (c.lo.b + c.hi.b), c.mean.b, 1e-9);
    EXPECT_LE(c.hi.L - c.lo.L, 2 * std::sqrt(3.0) * 1.5 * 2);
    EXPECT_LE(c.hi.a - c.lo.a, 2 * std::sqrt(3.0) * 1.5 * 2);
  }
  // The groups' shares: each cluster lies in one group (they are 30+ dE apart).
  std::array<double, 3> share{};
  for (const FlakeCluster& c : clusters) share[c.mean.L < 70 ? 0 : c.mean.L < 100 ? 1 : 2] += c.probability;
  EXPECT_NEAR(share[0], 0.5, 0.015);
  EXPECT_NEAR(share[1], 0.3, 0.015);
  EXPECT_NEAR(share[2], 0.2, 0.015);
  // The inverse CDF draws each cluster with its probability (to one step).
  ASSERT_EQ(cdf.size(), 500u);
  std::vector<int> hits(clusters.size(), 0);
  for (std::uint8_t c : cdf) {
    ASSERT_LT(c, clusters.size());
    ++hits[c];
  }
  for (std::size_t i = 0; i < clusters.size(); ++i)
    EXPECT_NEAR(hits[i] / 500.0, clusters[i].probability, 1.0 / 500 + 1e-12) << i;
}

TEST(FlakeClusters, FewColoursAreTheirOwnClustersAndNoneGiveNone) {
  std::vector<FlakeCluster> clusters;
  std::vector<std::uint8_t> cdf;
  cluster_flake_colours({{50, 1, 2}, {50, 1, 2}, {70, -3, 4}}, 50, 10, &clusters, &cdf);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_NEAR(clusters[0].probability, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(clusters[0].mean, (colour::Lab{50, 1, 2}));
  // Entry k holds the cluster where (k + 0.5) / 10 falls: 0.05 .. 0.65 below 2/3.
  EXPECT_EQ(cdf, (std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0, 1, 1, 1}));
  cluster_flake_colours({}, 50, 10, &clusters, &cdf);
  EXPECT_TRUE(clusters.empty());
  EXPECT_TRUE(cdf.empty());
}

TEST(FlakeClusters, EarthMoversDistanceIsTheOptimalTransport) {
  auto cl = [](double L, double a, double b, double p) {
    FlakeCluster c;
    c.mean = {L, a, b};
    c.probability = p;
    return c;
  };
  // A whole distribution moved by a vector: the vector's length.
  const std::vector<FlakeCluster> x = {cl(50, 0, 0, 0.5), cl(60, 10, 0, 0.3), cl(40, -5, 5, 0.2)};
  std::vector<FlakeCluster> y = x;
  for (auto& c : y) c.mean = {c.mean.L + 3, c.mean.a + 4, c.mean.b};
  EXPECT_NEAR(flake_colour_emd(x, y), 5.0, 1e-6);
  EXPECT_NEAR(flake_colour_emd(x, x), 0.0, 1e-9);
  // Two against two by hand: moving 0.5 from (0,0,0) and 0.5 from (10,0,0) to (0,0,0) x 0.3
  // and (10,0,0) x 0.7: 0.2 crosses 10 dE, the rest stays: 2.
  EXPECT_NEAR(flake_colour_emd({cl(0, 0, 0, 0.5), cl(10, 0, 0, 0.5)}, {cl(0, 0, 0, 0.3), cl(10, 0, 0, 0.7)}), 2.0, 1e-6);
  // Probabilities that do not sum to 1 are normalised; an empty side gives 0.
  EXPECT_NEAR(flake_colour_emd({cl(0, 0, 0, 2)}, {cl(0, 0, 7, 0.1)}), 7.0, 1e-6);
  EXPECT_EQ(flake_colour_emd({}, x), 0.0);
}

FlakeStats small_stats() {
  FlakeStats s;
  s.colour_space = colour::kLinearSrgb;
  s.images = 3;
  s.runs = 4;
  s.lifetime_deg = 6.1;
  s.step_deg = 1.0;
  FlakeSlice sl;
  sl.theta_f = 1;
  sl.theta_i = 2;
  sl.pixels = 1000;
  sl.glints = 30;
  sl.intensity_mean = 4.5;
  sl.intensity_quantiles = {1, 2, 3, 4, 5};
  std::vector<std::uint8_t> cdf;
  cluster_flake_colours(three_groups(30, 1), 50, 20, &sl.clusters, &sl.inverse_cdf);
  sl.runs = 4;
  sl.lifetime_deg = 6.1;
  s.slices.push_back(sl);
  s.pixels = 1000;
  s.glints = 30;
  s.instrument = {{15, 100, 5, 5.0, 3.0}, {45, 0, 0, 0, 0}, {75, 10, 0, 0, 0}};
  return s;
}

TEST(FlakesJson, RoundTripsAndRefusesDamage) {
  const FlakeStats s = small_stats();
  const Json j = flakes_to_json(s);
  EXPECT_EQ(j["format"], "paintlab-flakes");
  EXPECT_EQ(j["instrument"][1]["sparkle_area_percent"], nullptr);  // not measured: null, never 0
  const FlakeStats back = flakes_from_json(j, "f.json");
  EXPECT_EQ(flakes_to_json(back), j);
  EXPECT_EQ(back.slices[0].clusters.size(), s.slices[0].clusters.size());
  EXPECT_DOUBLE_EQ(back.area(), 0.03);

  auto refused = [&](Json bad) {
    try {
      flakes_from_json(bad, "f.json");
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  Json bad = j;
  bad["format_version"] = 2;
  EXPECT_THAT(refused(bad), HasSubstr("f.json: format_version 2 is newer than this software reads (1)"));
  bad = j;
  bad["slices"][0]["theta_i"] = 12;
  EXPECT_THAT(refused(bad), HasSubstr("f.json: slices[0]: bin (1, 12) outside the 12 x 12 slices"));
  bad = j;
  bad["slices"][0]["clusters"][0]["p"] = 0.9;
  EXPECT_THAT(refused(bad), HasSubstr("f.json: slices[0]: cluster probabilities sum to"));
  bad = j;
  bad["slices"][0]["inverse_cdf"][0] = 60;
  EXPECT_THAT(refused(bad), HasSubstr("f.json: slices[0]: inverse_cdf entry 60 names no cluster"));
  bad = j;
  bad["slices"][0]["glints"] = 5000;
  EXPECT_THAT(refused(bad), HasSubstr("f.json: slices[0]: more glints than pixels"));
  EXPECT_THAT(refused(Json{{"format", "other"}}), HasSubstr("f.json: not a flakes file"));
}

TEST(FlakeBtf, SlicesFollowTheLayoutRenderersReadAndTexelsTheStatistics) {
  FlakeStats s;
  s.options.num_theta_f = s.options.num_theta_i = 6;
  auto slice = [&](int f, int i, double area, std::vector<colour::Lab> colours) {
    FlakeSlice sl;
    sl.theta_f = f;
    sl.theta_i = i;
    sl.pixels = 10000;
    sl.glints = static_cast<std::uint64_t>(area * 10000);
    sl.glint_model_y = 1.0;
    if (!colours.empty()) cluster_flake_colours(colours, 50, 500, &sl.clusters, &sl.inverse_cdf);
    s.slices.push_back(sl);
  };
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.5);
  std::vector<colour::Lab> colours;
  for (int k = 0; k < 3000; ++k) {
    const colour::Lab c = k % 3 == 0 ? colour::Lab{60, 0, 0} : k % 3 == 1 ? colour::Lab{80, 10, -10} : colour::Lab{70, -10, 10};
    colours.push_back({c.L + g(rng), c.a + g(rng), c.b + g(rng)});
  }
  slice(0, 0, 0.3, colours);
  slice(2, 0, 0.1, colours);   // theta_I bin 0 holds theta_F bins 0..2 (bin 1 unobserved: zero)
  slice(0, 1, 0.0, {});        // observed, no glint: bin 1 holds no slice
  slice(1, 3, 0.05, colours);  // max_thetaI 4
  const FlakeBtf b = make_flake_btf(s, 64, 7);
  EXPECT_EQ(b.max_theta_i, 4);
  EXPECT_EQ(b.slice_lut, (std::vector<int>{0, 3, 3, 3, 5}));
  EXPECT_EQ(b.slices(), 5);
  EXPECT_EQ(b.slice_of(2, 0), 2);
  EXPECT_EQ(b.slice_of(3, 0), -1);  // past the column's theta_F bins: zero
  EXPECT_EQ(b.slice_of(0, 1), -1);
  EXPECT_EQ(b.slice_of(1, 3), 4);
  EXPECT_EQ(b.slice_of(0, 4), -1);  // at max_thetaI: zero
  b.check("btf");
  // Slice 0: texels glint with the slice's area, each in a cluster's chromaticity at a
  // lightness within its cuboid, times the model's luminance at the glints (here 1).
  const auto chroma = flake_chromaticities(s.slices[0].clusters);
  int lit = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const double* t = b.texel(0, x, y);
      const Eigen::Vector3d rgb(t[0], t[1], t[2]);
      mean += rgb;
      if (rgb.maxCoeff() <= 0) continue;
      ++lit;
      const colour::Lab lab = colour::srgb_to_lab(rgb);
      const colour::Lab unit = colour::srgb_to_lab(rgb / colour::srgb_to_xyz(rgb)[1]);
      bool found = false;
      for (std::size_t k = 0; k < chroma.size(); ++k) {
        const FlakeCluster& c = s.slices[0].clusters[k];
        found = found || (std::abs(unit.a - chroma[k].mean.a) < 1e-6 && std::abs(unit.b - chroma[k].mean.b) < 1e-6 &&
                          lab.L >= c.lo.L - 1e-6 && lab.L <= c.hi.L + 1e-6);
      }
      EXPECT_TRUE(found) << x << ", " << y;
    }
  EXPECT_NEAR(lit / 4096.0, 0.3, 4 * std::sqrt(0.3 * 0.7 / 4096));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.slice_mean[static_cast<std::size_t>(c)], mean[c] / 4096, 1e-12);
  // Slice 1 (theta_F bin 1, unobserved) is zero; the same statistics give the same BTF.
  for (int k = 0; k < 64 * 64 * 3; ++k) ASSERT_EQ(b.texels[64 * 64 * 3 + static_cast<std::size_t>(k)], 0.0);
  EXPECT_EQ(make_flake_btf(s, 64, 7), b);
  EXPECT_NE(make_flake_btf(s, 64, 8).texels, b.texels);
  // No glints: an empty BTF.
  FlakeStats none;
  none.slices = {s.slices[2]};
  const FlakeBtf e = make_flake_btf(none, 8);
  EXPECT_EQ(e.slices(), 0);
  EXPECT_EQ(e.slice_lut, (std::vector<int>{0}));
}

TEST(FlakeSparkleDraws, KeepTheAverageStayPutAndGlintWithTheArea) {
  FlakeStats s;
  s.options.num_theta_f = s.options.num_theta_i = 6;
  s.lifetime_deg = 5.0;
  FlakeSlice sl;
  sl.theta_f = 0;
  sl.theta_i = 0;
  sl.pixels = 1000;
  sl.glints = 200;  // area 0.2
  std::vector<colour::Lab> colours;
  for (int k = 0; k < 400; ++k) colours.push_back({k % 2 ? 150.0 : 120.0, k % 2 ? 8.0 : -6.0, 4.0});
  cluster_flake_colours(colours, 50, 500, &sl.clusters, &sl.inverse_cdf);
  s.slices = {sl};
  s.glints = 200;
  s.pixels = 1000;
  const FlakeSparkle sparkle(s);
  ASSERT_FALSE(sparkle.empty());
  const brdf::Rgb model(0.2, 0.3, 0.4);
  const Vec3 wi = Vec3(0.05, 0.02, 1).normalized(), wo = Vec3(-0.04, 0.0, 1).normalized();
  int lit = 0;
  brdf::Rgb sum = brdf::Rgb::Zero();
  const int n = 200000;
  for (int cell = 0; cell < n; ++cell) {
    const brdf::Rgb d = sparkle.delta(static_cast<std::uint64_t>(cell), wi, wo, model);
    lit += d.maxCoeff() > 0 ? 1 : 0;
    sum += d;
    ASSERT_EQ(d.matrix(), sparkle.delta(static_cast<std::uint64_t>(cell), wi, wo, model).matrix());  // deterministic
  }
  EXPECT_NEAR(lit / double(n), 0.2, 4 * std::sqrt(0.2 * 0.8 / n));
  // The sparkle averages to nothing: the smooth model stays the paint's mean (to the draws' noise).
  const double y = 0.2126 * 0.2 + 0.7152 * 0.3 + 0.0722 * 0.4;
  EXPECT_LT(std::abs((sum / n).matrix().dot(Eigen::Vector3d(0.2126, 0.7152, 0.0722))), 0.03 * y);
  // A glint stays put while the light moves a little (the half vector within its grid cell)
  // and changes over many lifetimes.
  int same = 0, cells = 0;
  const Vec3 wi2 = Vec3(0.06, 0.02, 1).normalized();  // h moves by about 0.3 deg
  for (int cell = 0; cell < 2000; ++cell) {
    const brdf::Rgb a = sparkle.delta(static_cast<std::uint64_t>(cell), wi, wo, model);
    if (a.maxCoeff() <= 0) continue;
    ++cells;
    same += sparkle.delta(static_cast<std::uint64_t>(cell), wi2, wo, model).matrix() == a.matrix() ? 1 : 0;
  }
  EXPECT_GT(same, 0.9 * cells);
  // Outside the measured slices nothing is drawn.
  const Vec3 far = Vec3(0.9, 0, 0.44).normalized();
  EXPECT_EQ(sparkle.delta(7, far, wo, model).matrix(), Eigen::Vector3d::Zero());
}

// A 320 x 240 sweep every 3 deg of the silver metallic paint (its flakes coloured), and
// its statistics against the true smooth BRDF.
struct SilverSweep {
  std::unique_ptr<test_support::SimSession> session;
  FlakeStats stats;
};

SilverSweep silver_sweep(bool sparkle, double noise_rel, double step_deg = 2.0) {
  const brdf::PaintSpec spec = brdf::load_paint_file(test::source_dir() / "paints" / "silver-metallic.toml");
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 25.0;
  o.step_deg = step_deg;
  o.start_deg = 20.0;
  o.stop_deg = 160.0;
  o.noise_rel = noise_rel;
  o.sparkle = sparkle;
  SilverSweep w;
  w.session = test_support::make_sim_session(sim::sim_paint(spec), o);
  const calib::RigCalibration cal = calib::RigCalibration::load(w.session->calibration_dir());
  const auto model = brdf::make_brdf(spec);
  w.stats = extract_flakes(w.session->frames, cal, *model);
  std::printf("%s", describe_flakes(w.stats).c_str());
  return w;
}

TEST(FlakeExtraction, APaintWithoutFlakesHasAnEmptyFlakeModel) {
  const SilverSweep w = silver_sweep(false, 0.02, 5.0);  // no runs to follow: every 5 deg is enough
  EXPECT_GT(w.stats.pixels, 100000u);
  EXPECT_EQ(w.stats.glints, 0u);
  EXPECT_TRUE(w.stats.empty());
  for (const FlakeSlice& s : w.stats.slices) EXPECT_TRUE(s.clusters.empty());
}

TEST(FlakeExtraction, FindsTheSimulatorsGlintsTheirLifetimeAndColours) {
  const SilverSweep w = silver_sweep(true, 0.02);
  const SilverSweep clean = silver_sweep(true, 1e-4);
  ASSERT_FALSE(w.stats.empty());
  EXPECT_GT(w.stats.glints, 2000u);
  // The pixel noise does not make or hide glints: the area of the busy slices as without noise.
  for (const FlakeSlice& s : clean.stats.slices) {
    if (s.glints < 300) continue;
    const FlakeSlice* n = w.stats.slice(s.theta_f, s.theta_i);
    ASSERT_NE(n, nullptr);
    EXPECT_NEAR(n->area(), s.area(), 0.1 * s.area()) << s.theta_f << ", " << s.theta_i;
  }
  // The lifetime of the paint's flakes (6.5 deg, paints/silver-metallic.toml).
  std::printf("lifetime %.2f deg (noise-free %.2f), %llu runs\n", w.stats.lifetime_deg, clean.stats.lifetime_deg,
              static_cast<unsigned long long>(w.stats.runs));
  EXPECT_GT(w.stats.runs, 200u);
  EXPECT_NEAR(w.stats.lifetime_deg, 6.5, 1.0);
}

}  // namespace
}  // namespace paintlab::fit
