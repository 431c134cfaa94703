// Interpolating paints (issue 17, docs/design.md): Golla and Klein's interpolation of the
// parameters, the colour table in CIELAB and the flake colour clusters by optimal transport,
// and `paintlab library interpolate`.
#include "paintlab/fitting/interpolate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "paintlab/core/error.h"
#include "paintlab/fitting/paint_library.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;

FlakeCluster cluster(double L, double a, double b, double p, double half = 2.0) {
  FlakeCluster c;
  c.mean = {L, a, b};
  c.lo = {L - half, a - half, b - half};
  c.hi = {L + half, a + half, b + half};
  c.probability = p;
  return c;
}

// A slice with `n` clusters drawn around (L, a, b), probabilities from the draw.
FlakeSlice slice(int f, int i, std::uint64_t pixels, std::uint64_t glints, int n, double L, double a, double b,
                 std::uint64_t seed) {
  FlakeSlice s;
  s.theta_f = f;
  s.theta_i = i;
  s.pixels = pixels;
  s.glints = glints;
  s.intensity_mean = 2.0 + 0.1 * f;
  s.glint_model_y = 0.3;
  s.intensity_quantiles = {0.7, 1.0, 1.8, 2.9, 4.0};
  s.runs = glints / 5;
  s.lifetime_deg = 5.0 + 0.5 * i;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> d(0.0, 6.0);
  std::uniform_real_distribution<double> u(0.2, 1.0);
  double total = 0.0;
  for (int k = 0; k < n; ++k) {
    s.clusters.push_back(cluster(L + d(rng), a + d(rng), b + d(rng), u(rng), 1.0 + 0.1 * k));
    total += s.clusters.back().probability;
  }
  for (FlakeCluster& c : s.clusters) {
    c.probability /= total;
    c.count = static_cast<std::uint64_t>(std::llround(c.probability * static_cast<double>(glints)));
  }
  std::stable_sort(s.clusters.begin(), s.clusters.end(),
                   [](const FlakeCluster& x, const FlakeCluster& y) { return x.probability > y.probability; });
  s.inverse_cdf = flake_inverse_cdf(s.clusters, 500);
  return s;
}

AxfPaint paint(const std::string& name, double scale, double hue, std::uint64_t seed) {
  AxfPaint p;
  p.name = name;
  p.model = "cook-torrance";
  p.colour_space = colour::kLinearSrgb;
  AxfCookTorrance ct;
  ct.params.kd = brdf::Rgb(0.03, 0.032, 0.035) * scale;
  ct.params.lobes = {{brdf::Rgb(0.06, 0.062, 0.066) * scale, 0.38, 0.85},
                     {brdf::Rgb(0.045, 0.046, 0.048) * scale, 0.16 * scale, 0.55},
                     {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04 * scale}};
  p.cook_torrance = ct;
  FlakeStats fs;
  fs.colour_space = colour::kLinearSrgb;
  fs.images = 100;
  fs.lifetime_deg = 5.0 * scale;
  fs.step_deg = 0.5;
  fs.slices = {slice(0, 1, 20000, static_cast<std::uint64_t>(2000 * scale), 50, 120, hue, -hue, seed),
               slice(1, 1, 10000, static_cast<std::uint64_t>(150 * scale), 12, 140, -hue, hue, seed + 1)};
  for (const FlakeSlice& s : fs.slices) {
    fs.pixels += s.pixels;
    fs.glints += s.glints;
    fs.runs += s.runs;
  }
  fs.instrument = {{15, 400, 40, 10.0, 2.5 * scale}, {45, 300, 3, 1.0, 1.2}, {75, 0, 0, 0.0, 0.0}};
  p.flake_stats = fs;
  p.flake_btf = make_flake_btf(fs, 8);
  return p;
}

// The clusters as (mean -> probability), for comparing a realisation with a parent whatever
// the order of equally likely clusters.
void expect_same_clusters(const std::vector<FlakeCluster>& got, const std::vector<FlakeCluster>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (const FlakeCluster& w : want) {
    const auto it = std::find_if(got.begin(), got.end(), [&](const FlakeCluster& g) { return g.mean == w.mean; });
    ASSERT_NE(it, got.end()) << w.mean.L;
    EXPECT_EQ(it->lo, w.lo);
    EXPECT_EQ(it->hi, w.hi);
    EXPECT_NEAR(it->probability, w.probability, 2e-9);
  }
}

void expect_same_paint(const AxfPaint& got, const AxfPaint& want) {
  EXPECT_EQ(got.cook_torrance->params, want.cook_torrance->params);
  ASSERT_TRUE(got.flake_stats);
  const FlakeStats& g = *got.flake_stats;
  const FlakeStats& w = *want.flake_stats;
  ASSERT_EQ(g.slices.size(), w.slices.size());
  for (std::size_t k = 0; k < w.slices.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(g.slices[k].pixels, w.slices[k].pixels);
    EXPECT_EQ(g.slices[k].glints, w.slices[k].glints);
    EXPECT_EQ(g.slices[k].intensity_mean, w.slices[k].intensity_mean);
    EXPECT_EQ(g.slices[k].intensity_quantiles, w.slices[k].intensity_quantiles);
    EXPECT_EQ(g.slices[k].lifetime_deg, w.slices[k].lifetime_deg);
    expect_same_clusters(g.slices[k].clusters, w.slices[k].clusters);
  }
  EXPECT_EQ(g.lifetime_deg, w.lifetime_deg);
  EXPECT_EQ(g.instrument, w.instrument);
}

TEST(Interpolation, WeightsOneAndZeroGiveEachParent) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  ASSERT_EQ(m.slices.size(), 2u);
  expect_same_paint(realise(m, 1.0, 0.0).paint, a);
  expect_same_paint(realise(m, 0.0, 1.0).paint, b);
}

TEST(Interpolation, TransportMovesEachSlicesWholeMassAtTheOptimalCost) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  for (const InterpolatableSlice& s : m.slices) {
    SCOPED_TRACE(s.theta_f);
    const auto& ca = a.flake_stats->slice(s.theta_f, s.theta_i)->clusters;
    const auto& cb = b.flake_stats->slice(s.theta_f, s.theta_i)->clusters;
    // A basic solution: at most ns + nt - 1 flows; out of each cluster its probability.
    EXPECT_LE(s.clusters.size(), ca.size() + cb.size() - 1);
    double total = 0.0, cost = 0.0;
    for (const FlakeCluster& c : ca) {
      double out = 0.0;
      for (const InterpolatableCluster& f : s.clusters)
        if (f.from == c) out += f.mass;
      EXPECT_NEAR(out, c.probability, 1e-8);
    }
    for (const FlakeCluster& c : cb) {
      double in = 0.0;
      for (const InterpolatableCluster& f : s.clusters)
        if (f.to == c) in += f.mass;
      EXPECT_NEAR(in, c.probability, 1e-8);
    }
    for (const InterpolatableCluster& f : s.clusters) {
      total += f.mass;
      cost += f.mass * std::sqrt(std::pow(f.from.mean.L - f.to.mean.L, 2) + std::pow(f.from.mean.a - f.to.mean.a, 2) +
                                 std::pow(f.from.mean.b - f.to.mean.b, 2));
    }
    EXPECT_NEAR(total, 1.0, 1e-9);
    EXPECT_NEAR(cost, s.transport_cost, 1e-9);
    EXPECT_NEAR(s.transport_cost, flake_colour_emd(ca, cb), 1e-12);
  }
}

// Equal masses: the optimal transport is an assignment (Birkhoff), so a brute force over the
// permutations is an independent solver.
TEST(Interpolation, TransportCostEqualsABruteForceAssignment) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> d(0.0, 10.0);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 2 + trial % 5;  // 2..6 clusters a side
    std::vector<FlakeCluster> a, b;
    for (int k = 0; k < n; ++k) {
      a.push_back(cluster(100 + d(rng), d(rng), d(rng), 1.0 / n));
      b.push_back(cluster(100 + d(rng), d(rng), d(rng), 1.0 / n));
    }
    std::vector<int> perm(static_cast<std::size_t>(n));
    std::iota(perm.begin(), perm.end(), 0);
    double best = INFINITY;
    do {
      double c = 0.0;
      for (int k = 0; k < n; ++k) {
        const auto& x = a[static_cast<std::size_t>(k)].mean;
        const auto& y = b[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])].mean;
        c += std::sqrt((x.L - y.L) * (x.L - y.L) + (x.a - y.a) * (x.a - y.a) + (x.b - y.b) * (x.b - y.b)) / n;
      }
      best = std::min(best, c);
    } while (std::next_permutation(perm.begin(), perm.end()));
    // Masses are scaled to 1e15 integers and costs to 1e-10 dE: the cost is optimal to 1e-9.
    EXPECT_NEAR(flake_transport(a, b).cost, best, 1e-9 * std::max(1.0, best)) << n << " clusters";
  }
}

// Displacement interpolation: at weights (1 - t, t) every flow has moved t of its way, so the
// realisation's distance to A is t EMD(A, B) and to B (1 - t) EMD(A, B): between the parents.
TEST(Interpolation, HalfWayColoursLieBetweenTheParents) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  for (double t : {0.25, 0.5, 0.75}) {
    const RealisedPaint r = realise(m, 1.0 - t, t);
    EXPECT_TRUE(r.clamped.empty());
    for (const FlakeSlice& s : r.paint.flake_stats->slices) {
      SCOPED_TRACE(testing::Message() << t << " slice " << s.theta_f);
      const auto& ca = a.flake_stats->slice(s.theta_f, s.theta_i)->clusters;
      const auto& cb = b.flake_stats->slice(s.theta_f, s.theta_i)->clusters;
      const double d = flake_colour_emd(ca, cb);
      EXPECT_GT(d, 5.0);
      EXPECT_NEAR(flake_colour_emd(s.clusters, ca), t * d, 1e-6 * d);
      EXPECT_NEAR(flake_colour_emd(s.clusters, cb), (1.0 - t) * d, 1e-6 * d);
      EXPECT_LE(s.clusters.size(), ca.size() + cb.size() - 1);
      EXPECT_EQ(s.inverse_cdf.size(), 500u);
      // The area and the other scalars interpolate linearly.
      const FlakeSlice& sa = *a.flake_stats->slice(s.theta_f, s.theta_i);
      const FlakeSlice& sb = *b.flake_stats->slice(s.theta_f, s.theta_i);
      EXPECT_NEAR(s.area(), (1 - t) * sa.area() + t * sb.area(), 1.0 / static_cast<double>(s.pixels));
      EXPECT_DOUBLE_EQ(s.lifetime_deg, (1 - t) * sa.lifetime_deg + t * sb.lifetime_deg);
    }
    const auto& p = r.paint.cook_torrance->params;
    EXPECT_NEAR(p.lobes[1].m, (1 - t) * 0.16 + t * 0.16 * 1.3, 1e-12);
    EXPECT_TRUE(r.paint.flake_btf);
  }
}

// Section 4.4 of the paper: the flakes' lightness and hue apart.
TEST(Interpolation, FlakeLightnessAndHueInterpolateApart) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  const RealisedPaint all = realise(m, 0.5, 0.5);
  const RealisedPaint lightness = realise(m, 0.5, 0.5, false, FlakeColourMode::LightnessOnly);
  const RealisedPaint hue = realise(m, 0.5, 0.5, false, FlakeColourMode::KeepLightness);
  // The rest of the paint is the same in all three.
  EXPECT_EQ(lightness.paint.cook_torrance->params, all.paint.cook_torrance->params);
  EXPECT_EQ(hue.paint.cook_torrance->params, all.paint.cook_torrance->params);
  for (const InterpolatableSlice& s : m.slices) {
    const FlakeSlice& sl = *lightness.paint.flake_stats->slice(s.theta_f, s.theta_i);
    const FlakeSlice& sh = *hue.paint.flake_stats->slice(s.theta_f, s.theta_i);
    // Lightness only: every cluster's (a*, b*) is one of the first paint's, its L* halfway.
    for (const FlakeCluster& c : sl.clusters) {
      const auto from = std::find_if(s.clusters.begin(), s.clusters.end(), [&](const InterpolatableCluster& f) {
        return f.from.mean.a == c.mean.a && f.from.mean.b == c.mean.b &&
               std::abs(c.mean.L - 0.5 * (f.from.mean.L + f.to.mean.L)) < 1e-12;
      });
      EXPECT_NE(from, s.clusters.end()) << c.mean.L << " " << c.mean.a;
    }
    // Keep lightness: every L* is the first paint's, (a*, b*) halfway.
    for (const FlakeCluster& c : sh.clusters) {
      const auto from = std::find_if(s.clusters.begin(), s.clusters.end(), [&](const InterpolatableCluster& f) {
        return f.from.mean.L == c.mean.L && std::abs(c.mean.a - 0.5 * (f.from.mean.a + f.to.mean.a)) < 1e-12 &&
               std::abs(c.mean.b - 0.5 * (f.from.mean.b + f.to.mean.b)) < 1e-12;
      });
      EXPECT_NE(from, s.clusters.end()) << c.mean.L << " " << c.mean.a;
    }
  }
}

TEST(Interpolation, ExtrapolationClampsAndSaysWhat) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  // 1.5 B - 0.5 A (B's parameters 1.3 A's) stays a paint: nothing clamped.
  RealisedPaint r = realise(m, -0.5, 1.5);
  EXPECT_TRUE(r.clamped.empty()) << r.clamped.front();
  // 20 A - 19 B: kd = (20 - 24.7) kd_A < 0, the medium lobe's m = 20 x 0.16 - 19 x 0.208 < 0,
  // the busy slice's area 20 x 0.1 - 19 x 0.13 < 0.
  r = realise(m, 20.0, -19.0);
  ASSERT_FALSE(r.clamped.empty());
  EXPECT_THAT(testing::PrintToString(r.clamped), HasSubstr("cook_torrance lobe 2 m"));
  EXPECT_THAT(testing::PrintToString(r.clamped), HasSubstr("cook_torrance kd[0]"));
  EXPECT_THAT(testing::PrintToString(r.clamped), HasSubstr("flake slice (0, 1) area"));
  EXPECT_GE(r.paint.cook_torrance->params.lobes[1].m, 1e-3);
  // Whatever the weights, the realisation is a paint the writer accepts.
  test::TempDir tmp;
  r.paint.name = "far-out";
  EXPECT_NO_THROW(write_axf_file(tmp / "far.axf.h5", r.paint));
}

TEST(Interpolation, ThreePaintsByIteratedTransport) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7), c = paint("copper", 0.8, -8.0, 11);
  const RealisedPaint r = interpolate_paints({a, b, c}, {0.5, 0.25, 0.25});
  // Linear parameters: the weighted sum, whatever the order of the transports.
  const auto& p = r.paint.cook_torrance->params;
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(p.kd[ch], 0.5 * a.cook_torrance->params.kd[ch] + 0.25 * b.cook_torrance->params.kd[ch] +
                              0.25 * c.cook_torrance->params.kd[ch], 1e-15);
  EXPECT_EQ(r.paint.name, "silver-50-gold-25-copper-25");
  EXPECT_EQ(r.paint.provenance.source, "interpolation: silver 0.5, gold 0.25, copper 0.25");
  for (const FlakeSlice& s : r.paint.flake_stats->slices) {
    double total = 0.0;
    for (const FlakeCluster& cl : s.clusters) total += cl.probability;
    EXPECT_NEAR(total, 1.0, 1e-12);
    EXPECT_LE(s.clusters.size(), 256u);
  }
  // Weight 1 on one paint of three gives that paint.
  expect_same_paint(interpolate_paints({a, b, c}, {0.0, 0.0, 1.0}).paint, c);
}

TEST(Interpolation, BadInputIsRefusedWithTheReason) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  auto refused = [](const std::function<void()>& f) { return test::error_message<DataError>(f); };
  EXPECT_THAT(refused([&] { interpolate_paints({a, b}, {0.5, 0.6}); }),
              HasSubstr("--weights: they sum to 1.1, not 1"));
  EXPECT_NO_THROW(interpolate_paints({a, b}, {0.5, 0.6}, {"", true}));
  EXPECT_THAT(refused([&] { interpolate_paints({a, b}, {1.0}); }), HasSubstr("--weights: 1 weights for 2 paints"));
  EXPECT_THAT(refused([&] { interpolate_paints({a}, {1.0}); }), HasSubstr("give 2 to 5"));
  EXPECT_THAT(refused([&] { interpolate_paints({a, b, a}, {1.0, -1.0, -1.0}, {"", true}); }),
              HasSubstr("the 2 largest weights sum to 0"));
  EXPECT_NO_THROW(interpolate_paints({a, b, a}, {0.5, -0.5, 1.0}));  // taken as a, a, b
  AxfPaint other = b;
  other.flake_stats->options.num_theta_f = other.flake_stats->options.num_theta_i = 10;
  EXPECT_THAT(refused([&] { interpolatable_paint(a, other); }), HasSubstr("flake slices of different layouts"));
  other = b;
  other.flake_stats.reset();
  other.flake_btf.reset();
  EXPECT_THAT(refused([&] { interpolatable_paint(a, other); }), HasSubstr("'silver' has measured flakes and 'gold' none"));
  other = b;
  other.cook_torrance->params.lobes.pop_back();
  EXPECT_THAT(refused([&] { interpolatable_paint(a, other); }), HasSubstr("3 and 2 lobes"));
  other = b;
  other.colour_space = colour::kCameraRgb;
  EXPECT_THAT(refused([&] { interpolatable_paint(a, other); }), HasSubstr("different colour spaces"));
  // A cosine-lobes paint has no form to interpolate; cosine-lobe weights beside a fit are left
  // out of the result (they approximate a parent), and said so.
  const brdf::CosineLobeParams lobes{{2, 50}, brdf::Rgb(0.1, 0.1, 0.1), {brdf::Rgb(0, 0, 0), brdf::Rgb(1, 1, 1)},
                                     {brdf::Rgb(0.1, 0.1, 0.1), brdf::Rgb(0, 0, 0)}};
  other = b;
  other.model = "cosine-lobes";
  other.cook_torrance.reset();
  other.cosine_lobes = lobes;
  EXPECT_THAT(refused([&] { interpolatable_paint(a, other); }), HasSubstr("'gold' is a cosine-lobes paint"));
  other = b;
  other.cosine_lobes = lobes;
  const RealisedPaint r = realise(interpolatable_paint(a, other), 0.5, 0.5, false);
  EXPECT_FALSE(r.paint.cosine_lobes);
  ASSERT_FALSE(r.notes.empty());
  EXPECT_THAT(r.notes.back(), HasSubstr("cosine-lobe weights (/cosine_lobes) are left out"));
  // A slice measured in one paint only is left out, and said so.
  other = b;
  other.flake_stats->slices.pop_back();
  const InterpolatablePaint m = interpolatable_paint(a, other);
  EXPECT_EQ(m.slices.size(), 1u);
  ASSERT_EQ(m.notes.size(), 1u);
  EXPECT_THAT(m.notes[0], HasSubstr("flake slice (1, 1) measured in 'silver' only: left out"));
}

TEST(Interpolation, TransportsReadBackEqualTheComputedOnesAndForeignOnesAreRefused) {
  const AxfPaint a = paint("silver", 1.0, 3.0, 1), b = paint("gold", 1.3, 12.0, 7);
  const InterpolatablePaint m = interpolatable_paint(a, b);
  const Json j = Json::parse(transports_to_json(m).dump());  // through text, as the cache file
  const InterpolatablePaint back = interpolatable_paint(a, b, j, "cache.json");
  ASSERT_EQ(back.slices.size(), m.slices.size());
  for (std::size_t k = 0; k < m.slices.size(); ++k) {
    EXPECT_NEAR(back.slices[k].transport_cost, m.slices[k].transport_cost, 1e-12);
    ASSERT_EQ(back.slices[k].clusters.size(), m.slices[k].clusters.size());
    for (std::size_t c = 0; c < m.slices[k].clusters.size(); ++c) {
      EXPECT_EQ(back.slices[k].clusters[c].from_index, m.slices[k].clusters[c].from_index);
      EXPECT_EQ(back.slices[k].clusters[c].to_index, m.slices[k].clusters[c].to_index);
      EXPECT_EQ(back.slices[k].clusters[c].mass, m.slices[k].clusters[c].mass);
      EXPECT_EQ(back.slices[k].clusters[c].from.mean, m.slices[k].clusters[c].from.mean);
    }
  }
  expect_same_paint(realise(back, 0.3, 0.7).paint, realise(m, 0.3, 0.7).paint);
  // The transports of two other paints: a cluster's flows do not carry its probability.
  const AxfPaint c = paint("bronze", 1.1, 20.0, 11);
  EXPECT_THAT(test::error_message<DataError>([&] { interpolatable_paint(a, c, j, "cache.json"); }),
              HasSubstr("cache.json: slice (0, 1)"));
  Json bad = j;
  bad["slices"][0]["cost"] = bad["slices"][0]["cost"].get<double>() + 1.0;
  EXPECT_THAT(test::error_message<DataError>([&] { interpolatable_paint(a, b, bad, "cache.json"); }),
              HasSubstr("is not the flows' cost"));
  bad = j;
  bad["slices"][0]["flows"][0][0] = 999;
  EXPECT_THAT(test::error_message<DataError>([&] { interpolatable_paint(a, b, bad, "cache.json"); }),
              HasSubstr("does not fit"));
}

TEST(Interpolation, ALibraryCachesTheTransportsOfItsPaints) {
  test::TempDir tmp;
  PaintLibrary l = PaintLibrary::open(tmp / "lib", true);
  l.add(paint("silver", 1.0, 3.0, 1), false);
  l.add(paint("gold", 1.3, 12.0, 7), false);
  l.add(paint("bronze", 1.1, 20.0, 11), false);
  bool cached = true;
  const InterpolatablePaint first = l.interpolatable("silver", "gold", &cached);
  EXPECT_FALSE(cached);
  const InterpolatablePaint again = l.interpolatable("silver", "gold", &cached);
  EXPECT_TRUE(cached);
  expect_same_paint(realise(again, 0.5, 0.5).paint, realise(first, 0.5, 0.5).paint);
  l.interpolatable("gold", "bronze", &cached);
  EXPECT_FALSE(cached);
  auto count = [&] {
    int n = 0;
    for (const auto& e : std::filesystem::directory_iterator(tmp / "lib" / "transports")) n += e.is_regular_file();
    return n;
  };
  EXPECT_EQ(count(), 2);
  EXPECT_TRUE(l.check().empty());
  // A damaged cache file is computed again (and rewritten).
  for (const auto& e : std::filesystem::directory_iterator(tmp / "lib" / "transports")) test::write_text(e.path(), "{");
  l.interpolatable("silver", "gold", &cached);
  EXPECT_FALSE(cached);
  l.interpolatable("silver", "gold", &cached);
  EXPECT_TRUE(cached);
  // Replacing gold drops both of its caches; removing silver drops its own.
  l.add(paint("gold", 1.2, 14.0, 8), true);
  EXPECT_EQ(count(), 0);
  l.interpolatable("silver", "bronze", &cached);
  EXPECT_FALSE(cached);
  EXPECT_EQ(count(), 1);
  l.remove("silver");
  EXPECT_EQ(count(), 0);
}

TEST(InterpolationCli, InterpolatesPaintsOfALibrary) {
  test::TempDir tmp;
  const std::string lib = (tmp / "lib").string();
  {
    PaintLibrary l = PaintLibrary::open(lib, true);
    l.add(paint("silver", 1.0, 3.0, 1), false);
    l.add(paint("gold", 1.3, 12.0, 7), false);
  }
  const std::string out = (tmp / "mix.axf.h5").string();
  auto r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights 0.75,0.25 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("wrote " + out + " (interpolation: silver 0.75, gold 0.25)"));
  EXPECT_THAT(r.err, HasSubstr("flake transports of 'silver' and 'gold': computed and cached in the library"));
  const AxfPaint mix = read_axf_file(out);
  EXPECT_EQ(mix.name, "silver-75-gold-25");
  EXPECT_NEAR(mix.cook_torrance->params.lobes[1].m, 0.75 * 0.16 + 0.25 * 0.208, 1e-12);
  EXPECT_TRUE(mix.flake_stats && mix.flake_btf);
  EXPECT_TRUE(validate_axf_file(out).ok());
  // The flakes' hue kept, their lightness interpolated.
  r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights 0.5,0.5 --flakes-lightness-only "
                         "--name hue-of-silver --out " + (tmp / "hue.axf.h5").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_axf_file(tmp / "hue.axf.h5").name, "hue-of-silver");
  EXPECT_THAT(r.err, HasSubstr("flake transports of 'silver' and 'gold': read from the library's cache"));
  // Extrapolation far out: written, with what was clamped.
  r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights=20,-19 --name far --out " +
                         (tmp / "far.axf.h5").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("clamped: cook_torrance lobe 2 m"));
  // Bad input: nothing written.
  const std::string bad = (tmp / "bad.axf.h5").string();
  r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights 0.5,0.6 --out " + bad);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--weights: they sum to 1.1"));
  r = test::run_paintlab("library interpolate --dir " + lib + " silver bronze --weights 0.5,0.5 --out " + bad);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("'bronze': neither a paint in library"));
  r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights 0.5,0.5 --keep-flake-lightness "
                         "--flakes-lightness-only --out " + bad);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("excludes"));
  r = test::run_paintlab("library interpolate --dir " + lib + " silver gold --weights 0.5,0.5 --out " + lib +
                         "/index.json");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(bad));
}

}  // namespace
}  // namespace paintlab::fit
