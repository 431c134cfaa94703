// Previews: the point-lit sphere has the brightness the Cook-Torrance formula predicts at
// its highlight (computed here by hand), the highlight sits where the mirror geometry puts
// it, tone mapping follows the stated sRGB curve, and environment lighting passes the
// white furnace test (a Lambertian sphere under a uniform sky has radiance = albedo).
#include "paintlab/fitting/preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>

#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/version.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/sim/paint.h"
#include "paintlab/acquisition/session_reader.h"
#include "paintlab/fitting/export.h"
#include "sim_session.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using namespace paintlab::fit;
using ::testing::HasSubstr;
using brdf::Rgb;
using brdf::Vec3;

namespace {

// Günther eq. 1 written out independently of brdf::CookTorrance.
Rgb cook_torrance_by_hand(const Rgb& kd, const Rgb& ks, double m, double r, const Vec3& n, const Vec3& wi,
                          const Vec3& wo) {
  const Vec3 h = (wi + wo).normalized();
  const double nh = n.dot(h), nl = n.dot(wi), nv = n.dot(wo), vh = wo.dot(h);
  const double tan2 = (1 - nh * nh) / (nh * nh);
  const double D = std::exp(-tan2 / (m * m)) / (m * m * std::pow(nh, 4));
  const double F = r + (1 - r) * std::pow(1 - vh, 5);
  const double G = std::min({1.0, 2 * nh * nv / vh, 2 * nh * nl / vh});
  return kd / paintlab::kPi + ks * (F * D * G / (paintlab::kPi * nl * nv));
}

}  // namespace

TEST(Preview, HighlightHasThePredictedBrightnessAndPlace) {
  const Rgb kd(0.2, 0.1, 0.05), ks(0.05, 0.06, 0.07);
  const double m = 0.2, r = 0.3;
  const brdf::CookTorrance paint(kd, {{ks, m, r}});
  PreviewOptions o;
  o.size_px = 96;
  o.light_azimuth_deg = 30;
  o.light_elevation_deg = 20;
  o.light_distance = 8;
  o.tone.exposure = 2.0;
  const Preview p = render_preview(paint, o);
  ASSERT_EQ(p.linear.width(), 96);

  // Every sphere pixel: value = f cos(theta_i) (d / r)^2 with the hand-written formula.
  int checked = 0;
  for (int y = 0; y < o.size_px; y += 7)
    for (int x = 0; x < o.size_px; x += 5) {
      Vec3 n, wi;
      double dist = 0;
      if (!preview_geometry(o, x, y, &n, &wi, &dist) || n.dot(wi) <= 0) continue;
      const Rgb expect = cook_torrance_by_hand(kd, ks, m, r, n, wi, Vec3::UnitZ()) * n.dot(wi) *
                         (o.light_distance / dist) * (o.light_distance / dist);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(p.linear.at(x, y, c), expect[c], 1e-5 * expect[c] + 1e-7);
      ++checked;
    }
  EXPECT_GT(checked, 50);

  // The brightest pixel is where the sphere normal is the half vector of view (+z) and
  // light (the light is 8 radii away: its direction at the highlight is the light's
  // direction from the centre to about 1/8 rad, so compare with the brightest-pixel search
  // over exact geometry instead).
  double best = -1;
  int bx = 0, by = 0;
  for (int y = 0; y < o.size_px; ++y)
    for (int x = 0; x < o.size_px; ++x) {
      Vec3 n, wi;
      double dist = 0;
      if (!preview_geometry(o, x, y, &n, &wi, &dist)) continue;
      const double score = n.dot((wi + Vec3::UnitZ()).normalized());
      if (score > best) best = score, bx = x, by = y;
    }
  EXPECT_NEAR(p.peak_x, bx, 2);
  EXPECT_NEAR(p.peak_y, by, 2);
  // Highlight to the upper right: the light is at +x (azimuth 30) and +y (elevation 20).
  EXPECT_GT(p.peak_x, o.size_px / 2);
  EXPECT_LT(p.peak_y, o.size_px / 2);

  // The PNG is the stated tone mapping of the linear value.
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(p.png.at(p.peak_x, p.peak_y, c), srgb_encode(2.0 * p.linear.at(p.peak_x, p.peak_y, c)));
  EXPECT_EQ(p.png.at(0, 0, 0), kPreviewBackground);  // background: grey
  // The side facing away from the light is black (n.wi < 0), distinct from the background.
  int unlit = 0;
  for (int y = 0; y < o.size_px; ++y)
    for (int x = 0; x < o.size_px; ++x) {
      Vec3 n, wi;
      double dist = 0;
      if (!preview_geometry(o, x, y, &n, &wi, &dist) || n.dot(wi) > -0.05) continue;
      ++unlit;
      for (int c = 0; c < 3; ++c) ASSERT_EQ(p.png.at(x, y, c), 0) << x << ", " << y;
    }
  EXPECT_GT(unlit, 20);
}

TEST(Preview, ToneMappingCurveAndAutoExposure) {
  EXPECT_EQ(srgb_encode(0.0), 0);
  EXPECT_EQ(srgb_encode(1.0), 255);
  EXPECT_EQ(srgb_encode(2.0), 255);
  EXPECT_EQ(srgb_encode(0.0031308 / 2), std::lround(12.92 * 0.0031308 / 2 * 255));
  EXPECT_EQ(srgb_encode(0.18), 118);  // mid grey: 1.055 * 0.18^(1/2.4) - 0.055 = 0.4614
  // tone_map (a table of the codes' boundaries) gives srgb_encode's code for every value: spread
  // over the range, and just either side of every boundary.
  {
    std::vector<float> values = {-1.0f, 0.0f, 1e-9f, 0.5f, 1.0f, 7.0f};
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.1);
    for (int i = 0; i < 20000; ++i) values.push_back(static_cast<float>(u(rng)));
    for (int k = 1; k < 256; ++k) {
      const double e = (k - 0.5) / 255.0;
      const float lin = static_cast<float>(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
      for (float d = lin, j = 0; j < 3; ++j, d = std::nextafter(d, 0.0f)) values.push_back(d);
      for (float d = lin, j = 0; j < 3; ++j, d = std::nextafter(d, 2.0f)) values.push_back(d);
    }
    ImageF img(static_cast<int>(values.size()), 1, 1);
    for (std::size_t i = 0; i < values.size(); ++i) img.at(static_cast<int>(i), 0) = values[i];
    const ImageU8 out = tone_map(img, 1.0);
    for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(out.at(static_cast<int>(i), 0), srgb_encode(values[i])) << values[i];
  }
  ImageF img(100, 1, 3, 0.0f);
  for (int x = 0; x < 100; ++x) img.at(x, 0, 1) = static_cast<float>(x + 1);  // 1..100 in green
  const double e = auto_exposure(img, {}, 99.0);
  EXPECT_NEAR(e, 1.0 / 99.0, 1e-12);
}

TEST(Preview, WhiteFurnaceUnderAUniformEnvironment) {
  const double albedo = 0.6;
  const brdf::Lambertian lambert(Rgb::Constant(albedo));
  ImageF sky(32, 16, 3, 1.0f);
  const EnvironmentMap env(sky, 1.0);
  const Preview p = render_preview(lambert, {.size_px = 32, .point_light = false, .environment_samples = 64}, &env);
  double sum = 0;
  int n = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      if (p.mask[static_cast<std::size_t>(y) * 32 + x]) {
        sum += p.linear.at(x, y, 0);
        ++n;
      }
  EXPECT_NEAR(sum / n, albedo, 0.01 * albedo);
}

TEST(Preview, EnvironmentSamplingPdfIsNormalised) {
  // A map with one bright texel region: the pdf integrates to 1 over the sphere and the
  // sampler's reported pdf equals pdf() at the sampled direction.
  ImageF map(16, 8, 3, 0.01f);
  for (int c = 0; c < 3; ++c) map.at(5, 2, c) = 50.0f;
  const EnvironmentMap env(map, 1.0);
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0, 1);
  double integral = 0;
  const int M = 200000;
  for (int i = 0; i < M; ++i) {
    const double z = 1 - 2 * u(rng), phi = 2 * paintlab::kPi * u(rng), s = std::sqrt(1 - z * z);
    integral += env.pdf(Vec3(s * std::cos(phi), s * std::sin(phi), z)) * 4 * paintlab::kPi;
  }
  EXPECT_NEAR(integral / M, 1.0, 0.02);
  int bright = 0;
  for (int i = 0; i < 1000; ++i) {
    double pdf = 0;
    const Vec3 d = env.sample(u(rng), u(rng), &pdf);
    EXPECT_NEAR(pdf, env.pdf(d), 1e-9 * pdf + 1e-12);
    int x, y;
    env.texel_of(d, &x, &y);
    bright += (x == 5 && y == 2) ? 1 : 0;
  }
  EXPECT_GT(bright, 900);  // nearly all samples go to the bright texel
}

TEST(Preview, GlossyPaintReflectsABrightSpotOfTheEnvironment) {
  // A bright patch straight behind the camera (+z, u = 0 column) shows up in the middle of
  // a glossy sphere, and not on a sky that lacks it.
  const brdf::CookTorrance glossy(Rgb::Constant(0.02), {{Rgb::Constant(0.2), 0.05, 0.5}});
  ImageF map(64, 32, 3, 0.02f);
  for (int y = 14; y < 18; ++y)
    for (int x : {0, 1, 62, 63})
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = 200.0f;
  const EnvironmentMap env(map, 1.0);
  const Preview p = render_preview(glossy, {.size_px = 48, .point_light = false, .environment_samples = 32}, &env);
  EXPECT_NEAR(p.peak_x, 24, 3);
  EXPECT_NEAR(p.peak_y, 24, 3);
  EXPECT_GT(p.peak.maxCoeff(), 20 * p.linear.at(6, 24, 0));  // the centre is far brighter than the rim
}

TEST(Preview, OptionsAreChecked) {
  const brdf::Lambertian lambert(Rgb::Constant(0.5));
  PreviewOptions o;
  o.size_px = 4;
  EXPECT_THROW(render_preview(lambert, o), OptionError);
  o = {};
  o.light_distance = 1.0;
  EXPECT_THROW(render_preview(lambert, o), OptionError);
}

// ---- the comparison with a measurement (simulated rig, truth calibration) ----

namespace {

brdf::PaintSpec silver() { return brdf::load_paint_file(test::source_dir() / "paints/silver-metallic.toml"); }

// A simulated session of the silver paint at 1 % noise (without sparkle unless asked), lit
// from `start` to `stop` deg in `step` deg steps; width x height px (0: the default size).
std::unique_ptr<test_support::SimSession> silver_session(double start, double stop, double step, int width = 0,
                                                         int height = 0, bool sparkle = false) {
  test_support::SimSessionOptions so;
  if (width > 0) so.width_px = width;
  if (height > 0) so.height_px = height;
  so.start_deg = start;
  so.stop_deg = stop;
  so.step_deg = step;
  so.sparkle = sparkle;
  so.noise_rel = 0.01;
  return test_support::make_sim_session(sim::sim_paint(silver()), so);
}

brdf::PaintSpec scaled(brdf::PaintSpec spec, double k) {
  auto& ct = std::get<brdf::CookTorranceParams>(spec.params);
  ct.kd *= k;
  for (auto& l : ct.lobes) l.ks *= k;
  return spec;
}

// A session folder (session.json, journal.jsonl, hdr/) around simulated HDR frames.
fs::path make_session_folder(const test_support::SimSession& sim, const fs::path& dir) {
  acq::SessionManifest m;
  m.sample = "panel-7";
  m.created_utc = utc_timestamp();
  m.software_version = software_version();
  m.rig_name = "sim-rig";
  for (const auto& f : sim.frames) m.angles_deg.push_back(f.angle_deg);
  m.exposures_s = {0.001};
  for (const char* name : {calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile})
    m.calibration[name] = sha256_file(sim.calibration_dir() / name);
  const acq::SessionDir session = acq::SessionDir::create(dir, m);
  fs::create_directories(dir / "hdr");
  for (std::size_t i = 0; i < sim.frames.size(); ++i) {
    acq::JournalEntry e;
    e.index = static_cast<int>(i);
    e.angle_deg = e.angle_read_deg = sim.frames[i].angle_deg;
    e.file = acq::SessionDir::hdr_name(e.index);
    fs::copy_file(sim.frames[i].path, dir / e.file);
    e.sha256 = sha256_file(dir / e.file);
    e.utc = utc_timestamp();
    session.journal().append(e);
  }
  return dir;
}

}  // namespace

TEST(Preview, ComparisonWithTheTruthMatchesAndAWrongPaintDoesNot) {
  auto sim = silver_session(60.0, 60.0, 1.0);
  const calib::RigCalibration cal = calib::RigCalibration::load(sim->calibration_dir());
  const ExrImage measured = read_exr(sim->frames[0].path);

  const auto truth = brdf::make_brdf(silver());
  const Comparison good = render_comparison(*truth, cal, measured, 60.0);
  EXPECT_GT(good.pixels_used, 2000u);
  EXPECT_NEAR(good.median_ratio, 1.0, 0.02);
  EXPECT_LT(good.log_rms, 0.01);  // 1 % noise over the 9 x 9 window: measured 0.0020
  EXPECT_EQ(good.png.width(), 3 * good.measured.width() + 8);
  EXPECT_EQ(good.png.height(), good.measured.height());

  const auto bright = brdf::make_brdf(scaled(silver(), 1.5));
  const Comparison bad = render_comparison(*bright, cal, measured, 60.0);
  EXPECT_NEAR(bad.median_ratio, 1.5, 0.04);
  EXPECT_GT(bad.log_rms, 0.3);
  // The difference panel is red (model brighter) where the good one is nearly black.
  long red_bad = 0, red_good = 0;
  const int w = good.measured.width(), off = 2 * (w + 4);
  for (int y = 0; y < good.png.height(); ++y)
    for (int x = 0; x < w; ++x) {
      red_good += good.png.at(off + x, y, 0);
      red_bad += bad.png.at(off + x, y, 0);
    }
  EXPECT_GT(red_bad, 4 * red_good);

  // Another light angle than the image's is caught: the highlight moves.
  const Comparison wrong_angle = render_comparison(*truth, cal, measured, 90.0);
  std::printf("comparison: truth median %.4f rms %.4f (%zu px); 1.5x paint median %.4f rms %.4f; wrong angle rms %.4f\n",
              good.median_ratio, good.log_rms, good.pixels_used, bad.median_ratio, bad.log_rms, wrong_angle.log_rms);
  EXPECT_GT(wrong_angle.log_rms, 2 * good.log_rms);
}

TEST(Preview, ComparisonWindowAveragesFlakeSparkle) {
  // With sparkle the flake lobes' light lands in a few bright pixels; pixel by pixel the
  // true paint looks wrong almost everywhere, over the comparison window it matches.
  auto sim = silver_session(60.0, 60.0, 1.0, 0, 0, true);
  const calib::RigCalibration cal = calib::RigCalibration::load(sim->calibration_dir());
  const ExrImage measured = read_exr(sim->frames[0].path);
  const auto truth = brdf::make_brdf(silver());
  CompareOptions pixelwise;
  pixelwise.window_px = 0;
  const Comparison raw = render_comparison(*truth, cal, measured, 60.0, pixelwise);
  const Comparison windowed = render_comparison(*truth, cal, measured, 60.0);
  const Comparison bright = render_comparison(*brdf::make_brdf(scaled(silver(), 1.5)), cal, measured, 60.0);
  std::printf("sparkle: pixel by pixel median %.4f rms %.4f; 9x9 window median %.4f rms %.4f (%zu px); 1.5x paint "
              "median %.4f rms %.4f\n",
              raw.median_ratio, raw.log_rms, windowed.median_ratio, windowed.log_rms, windowed.pixels_used,
              bright.median_ratio, bright.log_rms);
  EXPECT_GT(windowed.pixels_used, 2000u);
  EXPECT_LT(windowed.log_rms, raw.log_rms / 2);  // measured 0.077 and 0.35
  EXPECT_LT(windowed.log_rms, 0.15);
  EXPECT_NEAR(windowed.median_ratio, 1.0, 0.03);  // measured 1.0004
  EXPECT_NEAR(bright.median_ratio, 1.5, 0.08);
  CompareOptions bad;
  bad.window_px = 51;
  EXPECT_THROW(render_comparison(*truth, cal, measured, 60.0, bad), OptionError);
}

TEST(PreviewCli, RenderWritesPngAndHdrAndUsesAnEnvironment) {
  test::TempDir tmp;
  const std::string paint = (test::source_dir() / "paints/silver-metallic.toml").string();
  auto r = test::run_paintlab("render " + paint + " --out " + (tmp / "p.png").string() + " --size 48 --hdr " +
                              (tmp / "p.exr").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("wrote"));
  const RawImage png = read_raw_image(tmp / "p.png");
  EXPECT_EQ(png.pixels.width(), 48);
  EXPECT_EQ(png.pixels.channels(), 3);
  const ExrImage hdr = read_exr(tmp / "p.exr");
  EXPECT_EQ(hdr.width, 48);

  ExrImage env;
  env.width = 32;
  env.height = 16;
  for (const char* c : {"R", "G", "B"}) env.add(c, ImageF(32, 16, 1, 0.5f));
  write_exr(tmp / "sky.exr", env);
  r = test::run_paintlab("render " + paint + " --out " + (tmp / "e.png").string() + " --size 32 --samples 4 --env " +
                         (tmp / "sky.exr").string() + " --no-point-light");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(tmp / "e.png"));

  env.planes[0].at(3, 3) = -1.0f;
  write_exr(tmp / "bad.exr", env);
  r = test::run_paintlab("render " + paint + " --out " + (tmp / "b.png").string() + " --env " + (tmp / "bad.exr").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("bad.exr: pixel (3, 3)"));
  EXPECT_FALSE(fs::exists(tmp / "b.png"));
  r = test::run_paintlab("render " + paint + " --out " + (tmp / "c.png").string() + " --no-point-light");
  EXPECT_EQ(r.exit_code, 2);
}

TEST(PreviewCli, ExportASessionAndCompareWithIt) {
  auto sim = silver_session(20.0, 90.0, 35.0, 480, 360);
  test::TempDir tmp;
  const fs::path session = make_session_folder(*sim, tmp / "session");
  const std::string calib = " --calib " + sim->calibration_dir().string();

  const fs::path axf = tmp / "panel.axf.h5", merl = tmp / "panel.binary";
  auto r = test::run_paintlab("export " + session.string() + " --axf " + axf.string() + " --merl " + merl.string() +
                              " --lobes 1 --threads 2" + calib);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("AxF-like paint 'panel-7'"));
  EXPECT_THAT(r.out, HasSubstr("MERL .binary"));
  const AxfPaint p = read_axf_file(axf);
  EXPECT_EQ(p.model, "cook-torrance");
  ASSERT_TRUE(p.cook_torrance && p.cook_torrance->stddev && p.fit_quality);
  EXPECT_EQ(p.cook_torrance->params.lobes.size(), 1u);
  EXPECT_GT(p.fit_quality->bins_used, 1000);
  EXPECT_EQ(p.provenance.sample_name, "panel-7");
  EXPECT_EQ(p.provenance.rig_name, "sim-rig");
  EXPECT_EQ(p.provenance.calibration_sha256.size(), 4u);
  std::string both = read_file(session / "session.json") + read_file(session / "journal.jsonl");
  EXPECT_EQ(p.provenance.session_sha256, sha256_hex(both));
  const brdf::MerlTable t = brdf::read_merl(merl);
  EXPECT_EQ(fs::file_size(merl), brdf::kMerlFileBytes);
  EXPECT_GT(t.count_in_state(brdf::BinState::Measured), 100000u);  // measured + filled bins

  r = test::run_paintlab("render " + axf.string() + " --out " + (tmp / "cmp.png").string() + " --compare " +
                         session.string() + " --angle 60 --window 3" + calib);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("at table angle 55.0 deg"));
  EXPECT_THAT(r.out, HasSubstr("RMS log ratio"));
  EXPECT_TRUE(fs::exists(tmp / "cmp.png"));

  // Bad input: nothing written.
  r = test::run_paintlab("export " + session.string() + calib);
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("export " + session.string() + " --axf " + (tmp / "x.h5").string() + " --model phong" + calib);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(tmp / "x.h5"));
  // The filter-array sites are for the Cook-Torrance fit, and for a Bayer camera's session.
  r = test::run_paintlab("export " + session.string() + " --axf " + (tmp / "x.h5").string() +
                         " --model axf-carpaint --cfa-sites on" + calib);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--cfa-sites on is for the cook-torrance fit"));
  r = test::run_paintlab("export " + session.string() + " --axf " + (tmp / "x.h5").string() + " --cfa-sites on" + calib);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("cannot be fitted at its filter-array sites"));
  EXPECT_FALSE(fs::exists(tmp / "x.h5"));
}

// The functions `paintlab demo` calls (fitting/export.h), on one simulated session:
// export (bin once, fit, AxF-like + MERL + fit.json), an AxF-like file from fits in memory,
// library add, preview, comparison.
TEST(ExportSupport, ExportLibraryAndRenderAsFunctions) {
  auto sim = silver_session(30.0, 120.0, 30.0, 480, 360);
  test::TempDir tmp;
  const fs::path session = make_session_folder(*sim, tmp / "session");

  fit::ExportRequest r;
  r.inputs = {session};
  r.axf = tmp / "panel.axf.h5";
  r.merl = tmp / "panel.binary";
  r.fit_out = tmp / "fit.json";
  r.bin.calib_dir = sim->calibration_dir();
  r.lobes = 2;
  r.threads = 2;
  const fit::ExportResult e = fit::export_paint(r);
  ASSERT_TRUE(e.paint);
  ASSERT_EQ(e.fits.size(), 1u);
  EXPECT_EQ(e.lines.size(), 3u);  // fit.json, AxF-like, MERL
  EXPECT_GT(e.bin_s, 0.0);
  EXPECT_GT(e.fit_s, 0.0);
  EXPECT_GT(e.write_s, 0.0);
  EXPECT_EQ(*e.paint, read_axf_file(*r.axf));
  EXPECT_EQ(read_json_file(*r.fit_out), e.fits[0]);
  EXPECT_EQ(e.paint->name, "panel-7");
  EXPECT_EQ(e.paint->provenance.sample_name, "panel-7");
  ASSERT_TRUE(e.paint->fit_quality);
  EXPECT_EQ(e.paint->fit_quality->log_rms, e.fits[0]["residual"]["log_rms"].get<double>());
  EXPECT_EQ(fs::file_size(*r.merl), brdf::kMerlFileBytes);
  // The fit records the measurement as `paintlab fit` does (one bin_session for both).
  const Json& input = e.fits[0]["input"];
  EXPECT_EQ(input["kind"], "session");
  EXPECT_EQ(input["positions"], 4);
  EXPECT_EQ(input["margin_px"], 3.0);
  EXPECT_EQ(input["variance"], "hdr");
  EXPECT_EQ(input["estimator"], "mean");
  EXPECT_EQ(input["session_sha256"], acq::session_sha256(session));
  EXPECT_EQ(input["extraction"]["images"], 4);

  // The MERL file read as the public reference reader does (BRDFRead.cpp): int32 dims
  // 90 x 90 x 180, then all R, all G, all B doubles times 1/1500, 1.15/1500, 1.66/1500,
  // flat index phi_d + 180 (theta_d + 90 theta_h). Every measured bin holds the binned
  // value, and the binned values are the paint's BRDF at the bins' mean coordinates.
  {
    const std::string bytes = read_file(*r.merl);
    std::int32_t dims[3];
    std::memcpy(dims, bytes.data(), sizeof dims);
    EXPECT_EQ(dims[0], 90);
    EXPECT_EQ(dims[1], 90);
    EXPECT_EQ(dims[2], 180);
    const std::size_t n = 90 * 90 * 180;
    const double scale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};
    auto stored = [&](int c, std::size_t i) {
      double v;
      std::memcpy(&v, bytes.data() + sizeof dims + (c * n + i) * sizeof(double), sizeof v);
      return v * scale[c];
    };
    fit::SessionBinOptions bo;
    bo.calib_dir = sim->calibration_dir();
    bo.extraction.threads = bo.binning.threads = 2;
    const fit::BinnedTable binned = fit::bin_session(acq::SessionDir::open(session), bo).binned;
    const brdf::PaintSpec spec = silver();
    const auto& ct = std::get<brdf::CookTorranceParams>(spec.params);
    const brdf::CookTorrance truth(ct.kd, ct.lobes);
    std::size_t measured = 0, equal = 0;
    std::vector<double> ratio;
    for (std::size_t i = 0; i < n; ++i) {
      if (binned.table.state(i) != brdf::BinState::Measured) continue;
      ++measured;
      const brdf::Rgb v = binned.table.value(i);
      bool same = true;
      for (int c = 0; c < 3; ++c) same = same && std::abs(stored(c, i) - v[c]) <= 1e-12 * std::abs(v[c]);
      equal += same;
      const Eigen::Vector3d hd = binned.table.mean_coords(i);
      if (hd.x() > 0.15)  // off the clear coat's 1-deg mirror peak (1 % noise per sample)
        ratio.push_back(v.mean() / truth.eval_half_diff(hd.x(), hd.y(), hd.z()).mean());
    }
    EXPECT_GT(measured, 1000u);
    EXPECT_EQ(equal, measured);
    ASSERT_GT(ratio.size(), 200u);
    std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
    std::printf("MERL export: %zu measured bins, median measured/truth %.4f over %zu bins\n", measured,
                ratio[ratio.size() / 2], ratio.size());
    EXPECT_NEAR(ratio[ratio.size() / 2], 1.0, 0.01);  // measured 1.0003
  }

  // The same fit from memory with the session's provenance and another name.
  const acq::SessionDir sd = acq::SessionDir::open(session);
  const AxfPaint again = fit::export_axf(e.fits, fit::session_provenance(sd), tmp / "again.axf.h5", "again");
  EXPECT_EQ(again.name, "again");
  EXPECT_EQ(again.cook_torrance, e.paint->cook_torrance);
  EXPECT_EQ(again.fit_quality, e.paint->fit_quality);
  EXPECT_EQ(again.provenance.session_sha256, e.paint->provenance.session_sha256);
  EXPECT_THROW(fit::export_axf({}, {}, tmp / "none.axf.h5"), UsageError);
  EXPECT_FALSE(fs::exists(tmp / "none.axf.h5"));

  // From the fit.json: the provenance is the session's again, and --merl bins the session
  // the fit names into the same table, byte for byte.
  fit::ExportRequest from_fit;
  from_fit.inputs = {*r.fit_out};
  from_fit.axf = tmp / "from-fit.axf.h5";
  from_fit.merl = tmp / "from-fit.binary";
  from_fit.bin.calib_dir = sim->calibration_dir();
  from_fit.threads = 2;
  const fit::ExportResult ef = fit::export_paint(from_fit);
  ASSERT_TRUE(ef.paint);
  EXPECT_EQ(ef.paint->cook_torrance, e.paint->cook_torrance);
  EXPECT_EQ(ef.paint->provenance.session_sha256, e.paint->provenance.session_sha256);
  EXPECT_EQ(ef.paint->provenance.calibration_sha256, e.paint->provenance.calibration_sha256);
  EXPECT_THAT(ef.paint->provenance.source, HasSubstr("(a fit of session "));
  EXPECT_GT(ef.bin_s, 0.0);
  EXPECT_TRUE(read_file(*from_fit.merl) == read_file(*r.merl));

  // A session with a position still to measure is refused before anything is binned.
  fs::create_directories(tmp / "partial");
  for (const char* f : {"session.json", "journal.jsonl"}) fs::copy_file(session / f, tmp / "partial" / f);
  fs::copy(session / "hdr", tmp / "partial/hdr", fs::copy_options::recursive);
  Json manifest = read_json_file(tmp / "partial/session.json");
  manifest["plan"]["angles_deg"].push_back(170.0);
  write_json_file(tmp / "partial/session.json", manifest);
  fit::ExportRequest partial = r;
  partial.inputs = {tmp / "partial"};
  partial.axf = tmp / "partial.axf.h5";
  partial.merl.reset();
  partial.fit_out.reset();
  try {
    fit::export_paint(partial);
    ADD_FAILURE() << "an incomplete session was exported";
  } catch (const DataError& err) {
    EXPECT_THAT(err.what(), HasSubstr("1 of 5 light positions are missing (index 4)"));
    EXPECT_THAT(err.what(), HasSubstr("paintlab measure --resume"));
  }
  EXPECT_FALSE(fs::exists(tmp / "partial.axf.h5"));

  // Paint files: --model / --lobes belong to a session.
  fit::ExportRequest bad;
  bad.inputs = {*r.axf};
  bad.axf = tmp / "bad.axf.h5";
  bad.lobes = 1;
  EXPECT_THROW(fit::export_paint(bad), UsageError);
  bad.lobes.reset();
  bad.merl = tmp / "bad.binary";  // an AxF-like file holds no measurement
  EXPECT_THROW(fit::export_paint(bad), UsageError);
  EXPECT_FALSE(fs::exists(tmp / "bad.axf.h5"));

  const fit::LibraryEntry le = fit::library_add(tmp / "lib", *r.axf, false);
  EXPECT_EQ(le.name, "panel-7");
  EXPECT_EQ(le.log_rms, e.paint->fit_quality->log_rms);
  EXPECT_THROW(fit::library_add(tmp / "lib", *r.axf, false), DataError);
  EXPECT_NO_THROW(fit::library_add(tmp / "lib", *r.axf, true));
  EXPECT_EQ(fit::library_add(tmp / "lib", tmp / "again.axf.h5", false, "panel-7b").name, "panel-7b");
  EXPECT_EQ(PaintLibrary::open(tmp / "lib", false).list().size(), 2u);

  PreviewOptions po;
  po.size_px = 64;
  const Preview p = fit::render_preview_png(*r.axf, tmp / "preview.png", po, tmp / "preview.exr");
  EXPECT_EQ(read_raw_image(tmp / "preview.png").pixels.width(), 64);
  EXPECT_EQ(read_exr(tmp / "preview.exr").width, 64);
  EXPECT_GT(p.peak.maxCoeff(), 0.0);

  const fit::ComparisonResult c =
      fit::render_comparison_png(*r.axf, session, 100.0, tmp / "compare.png", sim->calibration_dir());
  EXPECT_EQ(c.angle_deg, 90.0);
  EXPECT_EQ(c.image, acq::SessionDir::hdr_name(2));
  EXPECT_GT(c.comparison.pixels_used, 1000u);
  std::printf("fitted 2-lobe model vs measured at 90 deg: median ratio %.4f, log rms %.4f (%zu px); bin %.2f s, "
              "fit %.2f s, write %.2f s\n",
              c.comparison.median_ratio, c.comparison.log_rms, c.comparison.pixels_used, e.bin_s, e.fit_s, e.write_s);
  EXPECT_NEAR(c.comparison.median_ratio, 1.0, 0.03);  // measured 1.0004
  EXPECT_LT(c.comparison.log_rms, 0.15);  // measured 0.079 (2 lobes fitted to a 3-lobe paint)
  EXPECT_EQ(read_raw_image(tmp / "compare.png").pixels.width(), c.comparison.png.width());
}
