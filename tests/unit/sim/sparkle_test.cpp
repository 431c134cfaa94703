#include <gtest/gtest.h>

#include "paintlab/sim/flakes.h"
#include "paintlab/sim/world.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;

TEST(Sparkle, CapProbabilityMatchesSampledFlakes) {
  const double m = 0.15, delta = deg_to_rad(6.5);
  sim::FlakeCapTable table(m, delta);
  sim::FlakeField field(1.0, 16000.0, m, 9);  // ~200k flakes on a unit sphere
  std::vector<sim::Flake> flakes;
  field.for_each_visible(Vec3(0, 0, 1e6), [&](const sim::Flake& f) { flakes.push_back(f); });
  sim::FlakeField all(1.0, 16000.0, m, 9);
  ASSERT_GT(flakes.size(), 80000u);
  for (double theta_h_deg : {0.0, 4.0, 9.0, 16.0, 25.0}) {
    double th = deg_to_rad(theta_h_deg);
    int hits = 0;
    for (const auto& f : flakes) {
      Vec3 h = frame_from_normal(f.position_dir) * spherical_to_vec(th, 0.7);
      if (f.normal.dot(h) >= std::cos(delta)) ++hits;
    }
    double p = table(std::cos(th));
    double n = static_cast<double>(flakes.size());
    double sigma = std::sqrt(std::max(p * (1 - p), 1.0 / n) / n);
    EXPECT_NEAR(hits / n, p, 4 * sigma + 1e-5) << "theta_h " << theta_h_deg << " deg";
    EXPECT_NEAR(p, sim::FlakeCapTable::integrate(m, delta, th), 1e-4);
  }
  // Small-cap limit: P ~ delta^2 / m^2 at the pole.
  EXPECT_NEAR(sim::FlakeCapTable::integrate(0.5, 0.01, 0.0), 0.01 * 0.01 / 0.25, 1e-5);
}

TEST(Sparkle, FlakeFieldIsAPoissonProcessOnTheSurface) {
  sim::FlakeField field(0.04, 2.0e7, 0.15, 3);
  double count = 0;
  field.for_each_visible(Vec3(0, 0, 1e6), [&](const sim::Flake&) { count += 1; });
  double expected = 2.0e7 * 2 * kPi * 0.04 * 0.04;  // a hemisphere
  EXPECT_NEAR(count, expected, 5 * std::sqrt(expected));
  // Stable: the same cell twice.
  auto a = field.cell(10, 20), b = field.cell(10, 20);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].normal, b[i].normal);
}

namespace {

struct SparkleRun {
  double ratio;           // sum(sparkle) / sum(smooth) over the patch
  double glint_frac;      // pixels at more than 3x the smooth value
  double dark_frac;       // pixels below half the smooth value
  std::size_t pixels;
};

SparkleRun sparkle_run(std::uint64_t seed, double angle_deg) {
  // A 150 mm lens: the sphere fills the 320 x 240 image and the highlight covers
  // thousands of pixels (the mean's spread over seeds is then about 0.3 %).
  sim::SimConfig cfg = sim::test::small_config(150.0);
  cfg.seed = seed;
  sim::SimWorld world(cfg);
  auto lobe = std::make_shared<sim::test::TestLobeBrdf>(0.0, 0.5, 0.3);
  sim::Sparkle sp;
  sp.density = 4.0;
  sp.roughness = 0.3;
  sp.lifetime_deg = 6.5;
  sp.flake_part = lobe;
  world.set_paint({lobe, sp});
  sim::RenderOptions smooth_opt;
  smooth_opt.sparkle = false;
  ImageF smooth = world.render_at(angle_deg, true, smooth_opt);
  ImageF sparkly = world.render_at(angle_deg, true);
  ImageF cov = world.sphere_coverage();
  double peak = 0;
  for (float v : smooth.values()) peak = std::max(peak, static_cast<double>(v));
  double s_sum = 0, f_sum = 0;
  std::size_t n = 0, glints = 0, dark = 0;
  for (std::size_t i = 0; i < smooth.size(); ++i) {
    if (cov.data()[i] < 1.0f || smooth.data()[i] < 1e-3 * peak) continue;
    s_sum += smooth.data()[i];
    f_sum += sparkly.data()[i];
    ++n;
    if (sparkly.data()[i] > 3 * smooth.data()[i]) ++glints;
    if (sparkly.data()[i] < 0.5 * smooth.data()[i]) ++dark;
  }
  return {f_sum / s_sum, static_cast<double>(glints) / n, static_cast<double>(dark) / n, n};
}

}  // namespace

TEST(Sparkle, AveragesToTheBrdfOverALargePatch) {
  for (std::uint64_t seed : {1ull, 2ull, 3ull}) {
    SparkleRun r = sparkle_run(seed, 10.0);
    std::printf("seed %llu: %zu pixels, sparkle/smooth = %.4f, glints %.2f %%, dark %.2f %%\n",
                static_cast<unsigned long long>(seed), r.pixels, r.ratio, 100 * r.glint_frac, 100 * r.dark_frac);
    EXPECT_GT(r.pixels, 50000u);
    EXPECT_NEAR(r.ratio, 1.0, 0.02) << "seed " << seed;
    EXPECT_GT(r.glint_frac, 0.01);  // it does sparkle
    EXPECT_GT(r.dark_frac, 0.05);
  }
}

TEST(Sparkle, PatternIsStableAndGlintsMoveWithTheLight) {
  sim::SimConfig cfg = sim::test::small_config(50.0);
  sim::SimWorld world(cfg);
  auto lobe = std::make_shared<sim::test::TestLobeBrdf>(0.0, 0.5, 0.2);
  sim::Sparkle sp;
  sp.density = 2.0;
  sp.flake_part = lobe;
  world.set_paint({lobe, sp});
  ImageF a = world.render_at(30.0, true), b = world.render_at(30.0, true), c = world.render_at(32.0, true);
  EXPECT_EQ(a.values(), b.values());
  sim::RenderOptions smooth;
  smooth.sparkle = false;
  ImageF sa = world.render_at(30.0, true, smooth), sc = world.render_at(32.0, true, smooth);
  // The set of glinting pixels changes when the light moves by 2 deg.
  int both = 0, only_a = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    bool ga = a.data()[i] > 3 * sa.data()[i] && sa.data()[i] > 0;
    bool gc = c.data()[i] > 3 * sc.data()[i] && sc.data()[i] > 0;
    both += ga && gc;
    only_a += ga && !gc;
  }
  EXPECT_GT(only_a, 50);
  EXPECT_GT(both, 10);  // flakes with a lifetime of 6.5 deg: many still glint
}

// `flake_seed`: another panel of the paint on the same rig. The flakes move, the smooth
// render (and the sensor's fixed pattern the calibration measured) stays.
TEST(Sparkle, FlakeSeedDrawsAnotherPanelOnTheSameRig) {
  sim::SimConfig cfg = sim::test::small_config(50.0);
  auto lobe = std::make_shared<sim::test::TestLobeBrdf>(0.0, 0.5, 0.2);
  sim::Sparkle sp;
  sp.density = 2.0;
  sp.flake_part = lobe;
  sim::SimWorld a(cfg);
  cfg.flake_seed = cfg.seed + 1;
  sim::SimWorld b(cfg);
  a.set_paint({lobe, sp});
  b.set_paint({lobe, sp});
  sim::RenderOptions smooth;
  smooth.sparkle = false;
  EXPECT_EQ(a.render_at(30.0, true, smooth).values(), b.render_at(30.0, true, smooth).values());
  const ImageF ga = a.render_at(30.0, true), gb = b.render_at(30.0, true);
  ASSERT_EQ(ga.size(), gb.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < ga.size(); ++i) differ += ga.data()[i] != gb.data()[i];
  EXPECT_GT(differ, ga.size() / 100);
}

TEST(SparkleColour, TintsAverageToGreyAndFollowTheirDistribution) {
  sim::FlakeColour colour;
  colour.tint_sd = 0.25;
  colour.interference = 0.3;
  colour.interference_chroma = 0.7;
  sim::FlakeField field(1.0, 20000.0, 0.15, 4);
  Vec3 sum = Vec3::Zero();
  double chroma_sum = 0;
  int n = 0, interference = 0;
  field.for_each_visible(Vec3(0, 0, 1e6), [&](const sim::Flake& f) {
    const sim::FlakeTint t = sim::draw_flake_tint(f.colour_bits, colour);
    // An interference flake's hue turns with the angle; its mean stays grey at any angle.
    const double turn = t.interference ? deg_to_rad(colour.interference_shift_deg * 20.0) : 0.0;
    sum += sim::flake_tint_rgb(t.chroma, t.hue_rad + turn);
    if (t.interference) {
      ++interference;
      EXPECT_DOUBLE_EQ(t.chroma, 0.7);
    } else {
      chroma_sum += t.chroma;
    }
    ++n;
  });
  ASSERT_GT(n, 100000);
  const Vec3 mean = sum / n;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], 1.0, 0.01) << "channel " << c;
  EXPECT_NEAR(static_cast<double>(interference) / n, 0.3, 0.01);
  // The chroma of ordinary flakes is Rayleigh(sd): mean sd sqrt(pi / 2) (clipping at 1 is
  // 4 sd away and does not show).
  EXPECT_NEAR(chroma_sum / (n - interference), 0.25 * std::sqrt(kPi / 2), 0.005);
  // A tint of chroma c is c away from grey, orthogonal to it, never negative.
  const Vec3 t = sim::flake_tint_rgb(0.5, 1.3);
  EXPECT_NEAR((t - Vec3::Ones()).norm(), 0.5, 1e-12);
  EXPECT_NEAR((t - Vec3::Ones()).sum(), 0.0, 1e-12);
  for (double h = 0; h < 2 * kPi; h += 0.1) EXPECT_GT(sim::flake_tint_rgb(1.0, h).minCoeff(), 0.18);
  // Grey paints draw grey flakes.
  EXPECT_EQ(sim::draw_flake_tint(12345, sim::FlakeColour{}).chroma, 0.0);
}

namespace {

// The glints of a colour render with coloured flakes: per channel sum(sparkle) /
// sum(smooth), and the spread of the glints' chromaticity r / (r + g + b) relative to the
// smooth value's.
struct ColourRun {
  Vec3 ratio;
  double glint_chroma_sd;
  std::size_t glints;
};

ColourRun colour_run(const sim::FlakeColour& colour, double angle_deg) {
  sim::SimConfig cfg = sim::test::small_config(150.0);
  cfg.seed = 5;
  sim::SimWorld world(cfg);
  auto lobe = std::make_shared<sim::test::TestLobeBrdf>(0.0, 0.5, 0.3);
  sim::Sparkle sp;
  sp.density = 4.0;
  sp.roughness = 0.3;
  sp.flake_part = lobe;
  sp.colour = colour;
  world.set_paint({lobe, sp});
  sim::RenderOptions rgb;
  rgb.mono = false;
  sim::RenderOptions smooth_opt = rgb;
  smooth_opt.sparkle = false;
  const ImageF smooth = world.render_at(angle_deg, true, smooth_opt);
  const ImageF sparkly = world.render_at(angle_deg, true, rgb);
  const ImageF cov = world.sphere_coverage();
  double peak = 0;
  for (float v : smooth.values()) peak = std::max(peak, static_cast<double>(v));
  Vec3 s_sum = Vec3::Zero(), f_sum = Vec3::Zero();
  double c_sum = 0, c2_sum = 0;
  std::size_t glints = 0;
  for (std::size_t i = 0; i < cov.size(); ++i) {
    if (cov.data()[i] < 1.0f || smooth.data()[3 * i] < 1e-3 * peak) continue;
    Vec3 s(smooth.data()[3 * i], smooth.data()[3 * i + 1], smooth.data()[3 * i + 2]);
    Vec3 f(sparkly.data()[3 * i], sparkly.data()[3 * i + 1], sparkly.data()[3 * i + 2]);
    s_sum += s;
    f_sum += f;
    if (f.sum() > 3 * s.sum()) {
      // The glint's own colour: what it adds to the smooth value, over the lobe's colour.
      const Vec3 g = (f - s).cwiseQuotient(Vec3(1.0, 0.8, 0.6));
      const double c = g[0] / g.sum();
      c_sum += c;
      c2_sum += c * c;
      ++glints;
    }
  }
  const double m = c_sum / std::max<std::size_t>(glints, 1);
  return {f_sum.cwiseQuotient(s_sum), std::sqrt(std::max(0.0, c2_sum / std::max<std::size_t>(glints, 1) - m * m)),
          glints};
}

}  // namespace

TEST(SparkleColour, ColouredFlakesKeepTheAverageAndColourTheGlints) {
  const ColourRun grey = colour_run(sim::FlakeColour{}, 10.0);
  sim::FlakeColour colour;
  colour.tint_sd = 0.3;
  colour.interference = 0.2;
  const ColourRun tinted = colour_run(colour, 10.0);
  std::printf("grey: ratio %.4f %.4f %.4f, glint chroma sd %.4f (%zu glints); tinted: ratio %.4f %.4f %.4f, sd %.4f\n",
              grey.ratio[0], grey.ratio[1], grey.ratio[2], grey.glint_chroma_sd, grey.glints, tinted.ratio[0],
              tinted.ratio[1], tinted.ratio[2], tinted.glint_chroma_sd);
  ASSERT_GT(grey.glints, 500u);
  ASSERT_GT(tinted.glints, 500u);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(tinted.ratio[c], 1.0, 0.02) << "channel " << c;
  EXPECT_LT(grey.glint_chroma_sd, 0.005);  // grey flakes: the glints have the lobe's colour
  EXPECT_GT(tinted.glint_chroma_sd, 0.03);
}
