// Multi-angle colourimetry and quality control (fitting/multiangle.h; `paintlab colour`,
// `paintlab qc`): the geometry convention, the colour of known paints against a test-side
// evaluation of the formulas, the flop index, QC verdicts and the errors a technician meets.
#include "paintlab/fitting/multiangle.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/paint_library.h"
#include "paintlab/core/json.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;
double deg(double rad) { return rad * 180.0 / kPi; }
double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return deg(std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
}

fs::path paint_file(const char* name) { return test::source_dir() / "paints" / name; }

// ---- A test-side evaluation of the formulas (models.md; CIE 15 for CIELAB), independent of
// the brdf and colour libraries ----

Eigen::Vector3d reference_ct_reflectance(const brdf::CookTorranceParams& p, const Eigen::Vector3d& wi,
                                         const Eigen::Vector3d& wo) {
  const Eigen::Vector3d n(0, 0, 1), h = (wi + wo).normalized();
  const double nh = n.dot(h), nl = n.dot(wi), nv = n.dot(wo), vh = wo.dot(h);
  const double tan2 = (1.0 - nh * nh) / (nh * nh);
  const double G = std::min({1.0, 2.0 * nh * nv / vh, 2.0 * nh * nl / vh});
  Eigen::Vector3d f = p.kd.matrix() / kPi;
  for (const auto& l : p.lobes) {
    const double D = std::exp(-tan2 / (l.m * l.m)) / (l.m * l.m * std::pow(nh, 4));
    const double F = l.r + (1.0 - l.r) * std::pow(1.0 - vh, 5);
    f += l.ks.matrix() * (F * D * G / (kPi * nl * nv));
  }
  return kPi * f;
}

colour::Lab reference_lab(const Eigen::Vector3d& rgb) {
  // IEC 61966-2-1 matrix; the white is that matrix applied to (1, 1, 1).
  Eigen::Matrix3d m;
  m << 0.4124, 0.3576, 0.1805, 0.2126, 0.7152, 0.0722, 0.0193, 0.1192, 0.9505;
  const Eigen::Vector3d xyz = m * rgb, white = m * Eigen::Vector3d::Ones();
  auto f = [](double t) {
    const double e = 216.0 / 24389.0, k = 24389.0 / 27.0;
    return t > e ? std::cbrt(t) : (k * t + 16.0) / 116.0;
  };
  const double fx = f(xyz[0] / white[0]), fy = f(xyz[1] / white[1]), fz = f(xyz[2] / white[2]);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

// ---- The geometry convention ----

TEST(MultiAngle, AspecularAnglesTurnTheSpecularDirectionTowardsTheIlluminator) {
  for (const Geometry& g : geometry_set("e2539")) {
    SCOPED_TRACE(g.name);
    const Eigen::Vector3d wi = g.towards_light(), wo = g.towards_viewer();
    const Eigen::Vector3d specular(-wi.x(), 0.0, wi.z());
    EXPECT_NEAR(wi.y(), 0.0, 1e-15);  // both in the plane of incidence
    EXPECT_NEAR(wo.y(), 0.0, 1e-15);
    EXPECT_NEAR(angle_between(wo, specular), std::abs(g.aspecular_deg), 1e-9);
    // Turned towards the illuminator for a positive angle, away from it for a negative one:
    // the signed in-plane angle from the specular direction (positive towards the light).
    auto in_plane = [](const Eigen::Vector3d& d) { return deg(std::atan2(d.x(), d.z())); };
    EXPECT_GT(in_plane(wi), in_plane(specular));
    EXPECT_NEAR(in_plane(wo) - in_plane(specular), g.aspecular_deg, 1e-9);
    EXPECT_GT(wo.z(), 0.0);
  }
  const Geometry normal = parse_geometry("45as45");
  EXPECT_NEAR(angle_between(normal.towards_viewer(), {0, 0, 1}), 0.0, 1e-9);
  const Geometry flop = parse_geometry("45as110");
  EXPECT_NEAR(angle_between(flop.towards_viewer(), {0, 0, 1}), 65.0, 1e-9);
  EXPECT_GT(flop.towards_viewer().x() * flop.towards_light().x(), 0.0);  // on the light's side
  const Geometry behind = parse_geometry("45as-15");
  EXPECT_NEAR(angle_between(behind.towards_viewer(), {0, 0, 1}), 60.0, 1e-9);
  EXPECT_LT(behind.towards_viewer().x() * behind.towards_light().x(), 0.0);
}

TEST(MultiAngle, NamedSetsHoldTheInstrumentsGeometries) {
  auto names = [](const std::vector<Geometry>& set) {
    std::vector<std::string> out;
    for (const auto& g : set) out.push_back(g.name);
    return out;
  };
  EXPECT_EQ(names(geometry_set("astm-e2194")), (std::vector<std::string>{"45as15", "45as45", "45as110"}));
  EXPECT_EQ(names(geometry_set("five-angle")),
            (std::vector<std::string>{"45as15", "45as25", "45as45", "45as75", "45as110"}));
  EXPECT_EQ(geometry_set("six-angle").front().name, "45as-15");
  EXPECT_EQ(geometry_set("e2539").size(), 11u);
}

TEST(MultiAngle, BadGeometriesAreUsageErrorsThatSayWhy) {
  try {
    parse_geometry("45as140");
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("below the surface"));
    EXPECT_THAT(e.what(), HasSubstr("-45 and 135"));
  }
  EXPECT_THROW(parse_geometry("45/15"), UsageError);
  EXPECT_THROW(parse_geometry("95as15"), UsageError);
  try {
    geometry_set("five-angels");
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("astm-e2194, five-angle, six-angle, e2539"));
  }
}

TEST(MultiAngle, CustomSetsComeFromTomlWithFileLineAndKeyInTheirErrors) {
  test::TempDir dir;
  {
    std::ofstream f(dir / "set.toml");
    f << "[[geometry]]\nillumination_deg = 45\naspecular_deg = -15\n\n[[geometry]]\nname = \"gloss\"\n"
         "illumination_deg = 30\naspecular_deg = 10\n";
  }
  const auto set = geometry_set((dir / "set.toml").string());
  ASSERT_EQ(set.size(), 2u);
  EXPECT_EQ(set[0].name, "45as-15");
  EXPECT_EQ(set[1].name, "gloss");
  EXPECT_DOUBLE_EQ(set[1].viewing_deg(), 20.0);
  {
    std::ofstream f(dir / "bad.toml");
    f << "[[geometry]]\nillumination_deg = 45\naspecular_deg = 15\n\n[[geometry]]\nillumination_deg = 60\n"
         "aspecular_deg = 160\n";
  }
  try {
    geometry_set((dir / "bad.toml").string());
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.line(), 7);
    EXPECT_THAT(e.key(), HasSubstr("aspecular_deg"));
    EXPECT_THAT(e.what(), HasSubstr("below the surface"));
  }
}

// ---- Colour values ----

TEST(MultiAngle, APerfectWhiteDiffuserIsOneAndLStar100AtEveryGeometry) {
  const brdf::Lambertian white(brdf::Rgb::Ones());
  for (const auto& c : colour_at(white, geometry_set("e2539"))) {
    SCOPED_TRACE(c.geometry.name);
    EXPECT_NEAR(c.reflectance.minCoeff(), 1.0, 1e-12);
    EXPECT_NEAR(c.reflectance.maxCoeff(), 1.0, 1e-12);
    EXPECT_NEAR(c.lab.L, 100.0, 1e-6);
    EXPECT_NEAR(c.lab.a, 0.0, 1e-6);
    EXPECT_NEAR(c.lab.b, 0.0, 1e-6);
  }
}

TEST(MultiAngle, PaintFilesMatchATestSideEvaluationOfTheFormulas) {
  for (const char* name : {"red-metallic.toml", "solid-blue.toml", "silver-metallic.toml"}) {
    SCOPED_TRACE(name);
    const brdf::PaintSpec spec = brdf::load_paint_file(paint_file(name));
    const brdf::CookTorranceParams& p = *spec.cook_torrance();
    const auto set = geometry_set("e2539");
    const MultiAngleColour c = paint_colour(paint_file(name), set);
    ASSERT_EQ(c.model.size(), set.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < set.size(); ++i) {
      const Eigen::Vector3d r = reference_ct_reflectance(p, set[i].towards_light(), set[i].towards_viewer());
      const colour::Lab ref = reference_lab(r);
      EXPECT_NEAR((c.model[i].reflectance - r).cwiseAbs().maxCoeff() / r.maxCoeff(), 0.0, 1e-9) << set[i].name;
      worst = std::max(worst, colour::delta_e_2000(c.model[i].lab, ref));
    }
    EXPECT_LT(worst, 0.3);
    EXPECT_LT(worst, 1e-3);  // the same formulas: only the rounding of two implementations differs
  }
}

TEST(MultiAngle, FlopIndexIsDuPontsFormula) {
  EXPECT_NEAR(flop_index(100.0, 50.0, 20.0), 2.69 * std::pow(80.0, 1.11) / std::pow(50.0, 0.86), 1e-12);
  EXPECT_NEAR(flop_index(100.0, 50.0, 20.0), 12.0522, 1e-4);
  EXPECT_LT(flop_index(20.0, 50.0, 30.0), 0.0);  // darker at the gloss keeps its sign
  // A solid paint hardly flops, a silver metallic does (X-Rite: flop index above ~10 for
  // strongly flopping silvers, near 0 for solids).
  const auto solid = paint_colour(paint_file("solid-blue.toml"), geometry_set("astm-e2194"));
  const auto silver = paint_colour(paint_file("silver-metallic.toml"), geometry_set("astm-e2194"));
  ASSERT_TRUE(solid.flop && silver.flop);
  EXPECT_GT(*silver.flop, 10.0);
  EXPECT_GT(*silver.flop, 3.0 * *solid.flop);
  EXPECT_FALSE(paint_colour(paint_file("solid-blue.toml"), {parse_geometry("45as45")}).flop);
}

TEST(MultiAngle, CameraRgbPaintsHaveNoCielab) {
  test::TempDir dir;
  AxfPaint p = axf_from_paint(brdf::load_paint_file(paint_file("red-metallic.toml")));
  p.colour_space = colour::kCameraRgb;
  write_axf_file(dir / "camera.axf.h5", p);
  try {
    paint_colour(dir / "camera.axf.h5", geometry_set("five-angle"));
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("linear camera RGB"));
    EXPECT_THAT(e.what(), HasSubstr("calibrate colour"));
  }
  p.colour_space = colour::kLinearSrgb;
  write_axf_file(dir / "srgb.axf.h5", p);
  const auto from_axf = paint_colour(dir / "srgb.axf.h5", geometry_set("five-angle"));
  const auto from_toml = paint_colour(paint_file("red-metallic.toml"), geometry_set("five-angle"));
  for (std::size_t i = 0; i < from_axf.model.size(); ++i)
    EXPECT_LT(colour::delta_e_2000(from_axf.model[i].lab, from_toml.model[i].lab), 1e-6);
}

TEST(MultiAngle, AMerlTablesNearestBinsAgreeWithItsPaint) {
  test::TempDir dir;
  const brdf::PaintSpec spec = brdf::load_paint_file(paint_file("solid-blue.toml"));
  brdf::write_merl(dir / "blue.binary", brdf::tabulate(*brdf::make_brdf(spec)));
  const auto set = geometry_set("six-angle");
  MeasuredInputOptions o;
  o.fit_file = paint_file("solid-blue.toml");
  const auto c = measured_paint_colour(dir / "blue.binary", set, o);
  ASSERT_EQ(c.measured.size(), set.size());
  for (std::size_t i = 0; i < set.size(); ++i) {
    SCOPED_TRACE(set[i].name);
    ASSERT_TRUE(c.measured[i]);
    EXPECT_GE(c.measured[i]->n, 20u);                   // a public table: one value per bin
    EXPECT_LE(c.measured[i]->angular_distance_deg, 2.0);
    EXPECT_LT(colour::delta_e_2000(c.measured[i]->lab, c.model[i].lab), 0.5);
  }
  const Json j = colour_json(c);
  EXPECT_TRUE(j["geometries"][0]["measured"]["n"].is_number());
  EXPECT_TRUE(j["geometries"][0]["de00"].is_number());
}

test_support::SimSessionOptions colour_sweep(double stop_deg) {
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.step_deg = 4.0;
  o.stop_deg = stop_deg;
  o.noise_rel = 0.02;
  o.sparkle = false;
  return o;
}

// A session of the red metallic in linear sRGB: the samples nearest each geometry against the
// truth, and against a fit made now (how well the fit reproduces the instrument's numbers).
TEST(ColourCli, ASessionsSamplesBesideTheModel) {
  const brdf::PaintSpec spec = brdf::load_paint_file(paint_file("red-metallic.toml"));
  const auto sim = test_support::make_sim_session(sim::sim_paint(spec), colour_sweep(180.0));
  const fs::path session = sim->dir / "session";
  test_support::write_session_folder(*sim, session, "Red", 0, colour::kLinearSrgb);
  const std::string common =
      "colour " + session.string() + " --calib " + sim->calibration_dir().string() + " --geometries astm-e2194 --json";
  auto r = test::run_paintlab(common + " --fit " + paint_file("red-metallic.toml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  Json j = Json::parse(r.out);
  for (const Json& g : j["geometries"]) {
    SCOPED_TRACE(g["name"].get<std::string>());
    ASSERT_TRUE(g["measured"].is_object());
    std::printf("%s: measured L* %.2f a* %.2f b* %.2f (n %d, within %.1f deg), truth L* %.2f, dE00 %.3f\n",
                g["name"].get<std::string>().c_str(), g["measured"]["L"].get<double>(),
                g["measured"]["a"].get<double>(), g["measured"]["b"].get<double>(), g["measured"]["n"].get<int>(),
                g["measured"]["angular_distance_deg"].get<double>(), g["model"]["L"].get<double>(),
                g["de00"].get<double>());
    // 2 % noise on some 20-30 samples: about 0.4 % per channel, dE00 0.2-0.4. A plain mean of
    // the same neighbours is biased by the lobe's slope across them (dE00 1.0-1.7).
    EXPECT_LT(g["de00"].get<double>(), 0.6);
    EXPECT_GE(g["measured"]["n"].get<int>(), 20);
    for (int c = 0; c < 3; ++c) {
      const double R = g["measured"]["R"][c].get<double>(), truth = g["model"]["R"][c].get<double>();
      const double se = g["measured"]["R_stderr"][c].get<double>();
      std::printf("  channel %d: R %.5f, truth %.5f, standard error %.5f\n", c, R, truth, se);
      EXPECT_GT(se, 0.0);
      EXPECT_LT(std::abs(R - truth), 4.0 * se + 0.002 * truth);
    }
  }
  // The model of a fit made now against the truth, evaluated independently in this test.
  r = test::run_paintlab(common + " --lobes 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = Json::parse(r.out);
  const auto set = geometry_set("astm-e2194");
  for (std::size_t i = 0; i < set.size(); ++i) {
    const Json& g = j["geometries"][i];
    SCOPED_TRACE(set[i].name);
    const Json& m = g["model"];
    const colour::Lab fitted{m["L"].get<double>(), m["a"].get<double>(), m["b"].get<double>()};
    const colour::Lab truth =
        reference_lab(reference_ct_reflectance(*spec.cook_torrance(), set[i].towards_light(), set[i].towards_viewer()));
    const double de_truth = colour::delta_e_2000(fitted, truth);
    std::printf("%s: fit L* %.2f, truth %.2f: dE00 %.3f; against the measured samples %.3f\n", set[i].name.c_str(),
                fitted.L, truth.L, de_truth, g["de00"].get<double>());
    EXPECT_LT(de_truth, 0.3);
    EXPECT_LT(g["de00"].get<double>(), 0.6);
  }
}

TEST(ColourCli, AGeometryTheSweepDoesNotCoverIsAnErrorThatSaysWhy) {
  const brdf::PaintSpec spec = brdf::load_paint_file(paint_file("solid-blue.toml"));
  const auto sim = test_support::make_sim_session(sim::sim_paint(spec), colour_sweep(60.0));
  const fs::path session = sim->dir / "session";
  test_support::write_session_folder(*sim, session, "Blue", 0, colour::kLinearSrgb);
  const auto r = test::run_paintlab("colour " + session.string() + " --calib " + sim->calibration_dir().string() +
                                    " --geometries astm-e2194 --fit " + paint_file("solid-blue.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("45as15 needs 75 deg between light and camera"));
  EXPECT_THAT(r.err, HasSubstr("--geometries"));
  // A session in camera RGB has no CIELAB.
  const fs::path mono = sim->dir / "mono";
  test_support::write_session_folder(*sim, mono, "Blue");
  const auto m = test::run_paintlab("colour " + mono.string() + " --calib " + sim->calibration_dir().string());
  EXPECT_EQ(m.exit_code, 2);
  EXPECT_THAT(m.err, HasSubstr("linear camera RGB"));
}

// ---- Quality control ----

MultiAngleColour shifted(MultiAngleColour c, double lightness_factor, double hue_rotation_deg) {
  const double r = hue_rotation_deg * kPi / 180.0;
  for (auto& a : c.model) {
    a.reflectance *= lightness_factor;
    a.lab = colour::srgb_to_lab(a.reflectance);
    const double na = a.lab.a * std::cos(r) - a.lab.b * std::sin(r), nb = a.lab.a * std::sin(r) + a.lab.b * std::cos(r);
    a.lab.a = na;
    a.lab.b = nb;
  }
  return c;
}

TEST(Qc, APaintAgainstItselfPassesWithDeltaEZero) {
  const auto r = quality_control(paint_file("red-metallic.toml"), paint_file("red-metallic.toml"), default_tolerances());
  EXPECT_TRUE(r.pass);
  ASSERT_EQ(r.angles.size(), 5u);
  for (const auto& a : r.angles) EXPECT_NEAR(a.de00, 0.0, 1e-9);
}

TEST(Qc, AKnownLightnessShiftAndHueRotationGiveTheExpectedDifferences) {
  const auto tol = default_tolerances("five-angle");
  std::vector<Geometry> set;
  for (const auto& t : tol) set.push_back(t.geometry);
  const MultiAngleColour standard = paint_colour(paint_file("red-metallic.toml"), set);
  // Reflectance +1 %: Y^(1/3) grows by 1.01^(1/3), so dL* = (L* + 16)(1.01^(1/3) - 1) and chroma
  // grows by the same factor.
  const auto lighter = quality_control(standard, shifted(standard, 1.01, 0.0), tol);
  for (const auto& a : lighter.angles) {
    SCOPED_TRACE(a.tolerance.geometry.name);
    EXPECT_NEAR(a.dL, (a.standard.L + 16.0) * (std::cbrt(1.01) - 1.0), 1e-6);
    EXPECT_NEAR(a.dC, a.standard.chroma() * (std::cbrt(1.01) - 1.0), 1e-6);
    EXPECT_NEAR(a.dH, 0.0, 1e-6);
  }
  // A hue rotation of 3 deg: dH* = 2 C* sin(1.5 deg), no lightness or chroma change.
  const auto rotated = quality_control(standard, shifted(standard, 1.0, 3.0), tol);
  for (const auto& a : rotated.angles) {
    SCOPED_TRACE(a.tolerance.geometry.name);
    EXPECT_NEAR(a.dL, 0.0, 1e-9);
    EXPECT_NEAR(a.dC, 0.0, 1e-9);
    EXPECT_NEAR(a.dH, 2.0 * a.standard.chroma() * std::sin(1.5 * kPi / 180.0), 1e-9);
  }
  // At a tight tolerance both fail, naming the difference; the red's hue rotation is dE00 > 1.
  std::vector<QcTolerance> tight = tol;
  for (auto& t : tight) {
    t.de00.reset();
    t.dL = 0.2;
    t.dH = 0.5;
  }
  const auto l = quality_control(standard, shifted(standard, 1.01, 0.0), tight);
  EXPECT_FALSE(l.pass);
  EXPECT_THAT(l.angles.front().failed, HasSubstr("dL*"));
  const auto h = quality_control(standard, shifted(standard, 1.0, 3.0), tight);
  EXPECT_FALSE(h.pass);
  EXPECT_THAT(h.angles.front().failed, HasSubstr("dH*"));
  EXPECT_FALSE(quality_control(standard, shifted(standard, 1.0, 3.0), tol).pass);
  EXPECT_TRUE(quality_control(standard, shifted(standard, 1.0, 0.2), tol).pass);
}

TEST(Qc, ToleranceFilesNameTheMissingGeometryFileAndLine) {
  test::TempDir dir;
  {
    std::ofstream f(dir / "tol.toml");
    f << "geometries = \"astm-e2194\"\n\n[[tolerance]]\ngeometry = \"45as15\"\nde00 = 2.0\nkL = 2\n\n"
         "[[tolerance]]\ngeometry = \"45as110\"\ndL = 1.0\ndH = 0.8\n";
  }
  try {
    load_tolerances(dir / "tol.toml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_THAT(e.what(), HasSubstr("45as45"));
    EXPECT_THAT(e.what(), HasSubstr("no [[tolerance]]"));
  }
  {
    std::ofstream f(dir / "tol.toml", std::ios::app);
    f << "\n[[tolerance]]\ngeometry = \"45as45\"\nde00 = 1.0\n";
  }
  const auto t = load_tolerances(dir / "tol.toml");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[1].geometry.name, "45as45");  // in the set's order
  EXPECT_DOUBLE_EQ(t[0].kL, 2.0);
  EXPECT_FALSE(t[2].de00.has_value());
  EXPECT_DOUBLE_EQ(*t[2].dH, 0.8);
  {
    std::ofstream f(dir / "none.toml");
    f << "[[tolerance]]\ngeometry = \"45as15\"\n";
  }
  EXPECT_THROW(load_tolerances(dir / "none.toml"), ConfigError);
}

// ---- The commands ----

TEST(ColourCli, JsonHasDesignsShape) {
  const auto r = test::run_paintlab("colour " + paint_file("red-metallic.toml").string() + " --geometries astm-e2194 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j["illuminant"], "D65");
  EXPECT_EQ(j["observer_deg"], 2);
  ASSERT_EQ(j["geometries"].size(), 3u);
  const Json& g = j["geometries"][2];
  EXPECT_EQ(g["name"], "45as110");
  EXPECT_EQ(g["illumination_deg"], 45.0);
  EXPECT_EQ(g["aspecular_deg"], 110.0);
  EXPECT_TRUE(g["measured"].is_null());
  EXPECT_TRUE(g["de00"].is_null());
  // At 45as110 the red metallic is nearly its diffuse albedo: R = kd = (0.18, 0.012, 0.010).
  EXPECT_NEAR(g["model"]["R"][0].get<double>(), 0.180, 0.002);
  EXPECT_NEAR(g["model"]["L"].get<double>(), reference_lab({0.180, 0.012, 0.010}).L, 0.3);
  EXPECT_TRUE(j["flop_index"].is_number());
  const auto table = test::run_paintlab("colour " + paint_file("red-metallic.toml").string());
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_THAT(table.out, HasSubstr("45as75"));
  EXPECT_THAT(table.out, HasSubstr("flop index"));
}

TEST(ColourCli, QcExitsZeroOnPassOneOnFailTwoOnBadInput) {
  const std::string red = paint_file("red-metallic.toml").string(), blue = paint_file("solid-blue.toml").string();
  EXPECT_EQ(test::run_paintlab("qc " + red + " " + red).exit_code, 0);
  const auto fail = test::run_paintlab("qc " + red + " " + blue + " --json");
  EXPECT_EQ(fail.exit_code, 1);
  EXPECT_FALSE(Json::parse(fail.out)["pass"].get<bool>());
  const auto bad_set = test::run_paintlab("colour " + red + " --geometries five-angels");
  EXPECT_EQ(bad_set.exit_code, 2);
  EXPECT_THAT(bad_set.err, HasSubstr("five-angels"));
  const auto below = test::run_paintlab("colour " + red + " --geometries /nonexistent/set.toml");
  EXPECT_EQ(below.exit_code, 2);
  test::TempDir dir;
  {
    std::ofstream f(dir / "tol.toml");
    f << "geometries = \"five-angle\"\n[[tolerance]]\ngeometry = \"45as15\"\nde00 = 1.0\n";
  }
  const auto tol = test::run_paintlab("qc " + red + " " + red + " --tolerances " + (dir / "tol.toml").string());
  EXPECT_EQ(tol.exit_code, 2);
  EXPECT_THAT(tol.err, HasSubstr("tol.toml:1"));
  EXPECT_THAT(tol.err, HasSubstr("45as25 of set 'five-angle' has no [[tolerance]]"));
  const auto missing = test::run_paintlab("qc " + red + " /nonexistent/paint.toml");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/paint.toml"));
}

// ---- Colour match against a library ----

// A library of the built-in paints, a red 2 % lighter than the red metallic, and a paint in
// camera RGB (which has no CIELAB).
fs::path colour_library(const fs::path& dir) {
  const fs::path lib = dir / "lib";
  PaintLibrary l = PaintLibrary::open(lib, true);
  for (const char* name : {"red-metallic.toml", "solid-blue.toml", "silver-metallic.toml"})
    l.add(axf_from_paint(brdf::load_paint_file(paint_file(name))), false);
  brdf::PaintSpec red = brdf::load_paint_file(paint_file("red-metallic.toml"));
  red.name = "red-lighter";
  auto& ct = std::get<brdf::CookTorranceParams>(red.params);
  ct.kd *= 1.02;
  for (auto& lobe : ct.lobes) lobe.ks *= 1.02;
  l.add(axf_from_paint(red), false);
  AxfPaint camera = axf_from_paint(brdf::load_paint_file(paint_file("solid-blue.toml")));
  camera.name = "blue-camera-rgb";
  camera.colour_space = colour::kCameraRgb;
  l.add(camera, false);
  return lib;
}

TEST(LibraryMatch, RanksThePaintsByTheirWorstGeometryDeltaE) {
  test::TempDir dir;
  const fs::path lib_dir = colour_library(dir.path());
  const PaintLibrary lib = PaintLibrary::open(lib_dir, false);
  // The index stores each sRGB paint's five-angle CIELAB, the camera-RGB one none.
  const auto set = geometry_set(kDefaultGeometrySet);
  const LibraryEntry red = lib.find("red-metallic");
  const auto truth = paint_colour(paint_file("red-metallic.toml"), set);
  ASSERT_EQ(red.colour.size(), set.size());
  for (std::size_t i = 0; i < set.size(); ++i) {
    EXPECT_EQ(red.colour[i].first, set[i].name);
    EXPECT_LT(colour::delta_e_2000(red.colour[i].second, truth.model[i].lab), 1e-6);
  }
  EXPECT_TRUE(lib.find("blue-camera-rgb").colour.empty());

  const LibraryMatchResult r = library_match(lib, truth, set);
  ASSERT_EQ(r.matches.size(), 4u);
  EXPECT_EQ(r.from_index, 4u);
  EXPECT_EQ(r.from_files, 0u);
  EXPECT_EQ(r.skipped, std::vector<std::string>{"blue-camera-rgb"});
  EXPECT_EQ(r.matches[0].name, "red-metallic");
  EXPECT_NEAR(r.matches[0].worst_de00, 0.0, 1e-9);
  EXPECT_EQ(r.matches[1].name, "red-lighter");
  // Reflectance x 1.02 lifts L* by (L* + 16)(1.02^(1/3) - 1): 0.4-0.5 at these angles.
  EXPECT_GT(r.matches[1].worst_de00, 0.2);
  EXPECT_LT(r.matches[1].worst_de00, 1.0);
  EXPECT_GT(r.matches[2].worst_de00, 10.0);
  EXPECT_LE(r.matches[1].mean_de00, r.matches[1].worst_de00);
}

TEST(LibraryMatch, AVersionOneIndexStillReadsAndMatchesFromTheFiles) {
  test::TempDir dir;
  const fs::path lib_dir = colour_library(dir.path());
  Json j = read_json_file(lib_dir / kLibraryIndexFile);
  EXPECT_EQ(j["format_version"], 3);
  j["format_version"] = 1;
  for (Json& p : j["paints"]) p.erase("colour");
  write_json_file(lib_dir / kLibraryIndexFile, j);
  const PaintLibrary lib = PaintLibrary::open(lib_dir, false);
  EXPECT_TRUE(lib.find("red-metallic").colour.empty());
  const auto set = geometry_set("astm-e2194");
  const LibraryMatchResult r = library_match(lib, paint_colour(paint_file("red-metallic.toml"), set), set);
  EXPECT_EQ(r.from_index, 0u);
  EXPECT_EQ(r.from_files, 4u);
  ASSERT_EQ(r.matches.size(), 4u);
  EXPECT_EQ(r.matches[0].name, "red-metallic");
  EXPECT_EQ(r.matches[1].name, "red-lighter");
}

TEST(LibraryMatch, CommandListsThePaintsWithinMaxDe) {
  test::TempDir dir;
  const fs::path lib = colour_library(dir.path());
  auto r = test::run_paintlab("library match --dir " + lib.string() + " " + paint_file("red-metallic.toml").string() +
                              " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  ASSERT_EQ(j["matches"].size(), 2u);  // the default --max-de 1.0
  EXPECT_EQ(j["matches"][0]["name"], "red-metallic");
  EXPECT_EQ(j["matches"][1]["name"], "red-lighter");
  EXPECT_THAT(r.err, HasSubstr("blue-camera-rgb"));
  // PAINT may be a name in the library; nothing within a tight limit says which is closest.
  r = test::run_paintlab("library match --dir " + lib.string() + " solid-blue --max-de 0.5 --geometries astm-e2194");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("solid-blue"));
  r = test::run_paintlab("library match --dir " + lib.string() + " " + paint_file("pearlescent.toml").string() +
                         " --max-de 0.01");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("no paint within dE00 0.01; the closest is '"));
  r = test::run_paintlab("library list --dir " + lib.string());
  EXPECT_THAT(r.out, HasSubstr("L* a* b* AT 45as45"));
  r = test::run_paintlab("library match --dir " + lib.string() + " no-such-paint");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("no-such-paint"));
}

}  // namespace
}  // namespace paintlab::fit
