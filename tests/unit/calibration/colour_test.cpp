// Colour characterisation on a chart: the ColorChecker reference read from its CGATS file, a
// synthetic camera (a channel mix unlike sRGB, per-channel gains, an unknown exposure) whose
// colour matrix is recovered, the root-polynomial terms exercised by a camera no matrix can
// describe, noise against the chart targets, and the refusals.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <cstdio>
#include <functional>
#include <random>

#include "paintlab/calibration/check.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using ::testing::HasSubstr;

namespace {

std::filesystem::path colorchecker() { return test::data_dir() / "colorchecker" / "ColorChecker.cie"; }

// A camera's channel mix from scene linear sRGB (rows: camera R, G, B), with gains.
Eigen::Matrix3d camera_mix() {
  Eigen::Matrix3d m;
  m << 0.80, 0.25, -0.05,  //
      0.10, 0.85, 0.05,    //
      0.02, 0.20, 0.78;
  return Eigen::Vector3d(0.55, 1.0, 0.7).asDiagonal() * m;
}

// What the camera records of each patch: k * mix * sRGB(patch), with relative noise.
std::vector<PatchMeasurement> shoot(const ChartReference& ref, double exposure, double noise_rel = 0.0,
                                    const std::function<colour::Rgb(const colour::Rgb&)>& camera = {}) {
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> n01;
  std::vector<PatchMeasurement> out;
  const std::vector<colour::Xyz> xyz = ref.xyz_d65();
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    const colour::Rgb srgb = colour::xyz_to_srgb(xyz[i]);
    colour::Rgb c = camera ? camera(srgb) : colour::Rgb(camera_mix() * srgb);
    c *= exposure;
    for (int ch = 0; ch < 3; ++ch) c[ch] *= 1.0 + noise_rel * n01(rng);
    out.push_back({ref.patches[i], c, c * noise_rel, 400, false});
  }
  return out;
}

}  // namespace

TEST(ChartReference, ReadsArgyllsColorCheckerCgatsFile) {
  const ChartReference ref = ChartReference::load(colorchecker());
  ASSERT_EQ(ref.patches.size(), 24u);
  EXPECT_EQ(ref.patches.front(), "A01");
  EXPECT_EQ(ref.patches.back(), "D06");
  EXPECT_EQ(ref.index_of("D01"), 18);
  EXPECT_EQ(ref.index_of("E01"), -1);
  EXPECT_NEAR(ref.lab[0].L, 37.99, 1e-9);
  EXPECT_NEAR(ref.lab[0].a, 13.56, 1e-9);
  EXPECT_NEAR(ref.lab[0].b, 14.06, 1e-9);
  EXPECT_NEAR(ref.lab[18].L, 96.54, 1e-9);
  // Adapted to D65 the neutral patches stay neutral and keep their lightness.
  const std::vector<colour::Lab> d65 = ref.lab_d65();
  for (int i = 18; i < 24; ++i) {
    EXPECT_LT(d65[static_cast<std::size_t>(i)].chroma(), 1.5) << ref.patches[static_cast<std::size_t>(i)];
    EXPECT_NEAR(d65[static_cast<std::size_t>(i)].L, ref.lab[static_cast<std::size_t>(i)].L, 0.05);
  }
}

TEST(ChartReference, ReadsXyzFieldsAsWellAsLab) {
  const ChartReference lab = ChartReference::load(colorchecker());
  test::TempDir dir;
  std::string text =
      "CGATS.17\nORIGINATOR \"paintlab test\"\nNUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_ID XYZ_X XYZ_Y "
      "XYZ_Z\nEND_DATA_FORMAT\nNUMBER_OF_SETS 24\nBEGIN_DATA\n";
  for (std::size_t i = 0; i < lab.patches.size(); ++i) {
    const colour::Xyz x = 100.0 * colour::lab_to_xyz(lab.lab[i], colour::d50());
    text += fmt::format("{} {:.6f} {:.6f} {:.6f}\n", lab.patches[i], x.x(), x.y(), x.z());
  }
  text += "END_DATA\n";
  test::write_text(dir / "chart.cgats", text);
  const ChartReference xyz = ChartReference::load(dir / "chart.cgats");
  ASSERT_EQ(xyz.patches, lab.patches);
  for (std::size_t i = 0; i < lab.patches.size(); ++i)
    EXPECT_LT(colour::delta_e_2000(xyz.lab[i], lab.lab[i]), 1e-4) << lab.patches[i];
}

TEST(ChartReference, BadFilesAreRefusedNamingTheFileThePatchAndTheField) {
  test::TempDir dir;
  EXPECT_THAT(test::error_message<IoError>([&] { ChartReference::load(dir / "none.cie"); }),
              HasSubstr("no such file"));
  test::write_text(dir / "not.cie", "hello\n");
  EXPECT_THAT(test::error_message<DataError>([&] { ChartReference::load(dir / "not.cie"); }),
              HasSubstr("not.cie: not a CGATS (IT8.7) file"));
  const std::string head =
      "CGATS.17\nNUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_ID LAB_L LAB_A LAB_B\nEND_DATA_FORMAT\n";
  test::write_text(dir / "bad.cie", head + "NUMBER_OF_SETS 2\nBEGIN_DATA\nA01 37.99 13.56 14.06\nA02 x 1 2\nEND_DATA\n");
  EXPECT_THAT(test::error_message<DataError>([&] { ChartReference::load(dir / "bad.cie"); }),
              HasSubstr("bad.cie: patch 'A02': LAB_L is not a number"));
  test::write_text(dir / "twice.cie", head + "NUMBER_OF_SETS 2\nBEGIN_DATA\nA01 37.99 13.56 14.06\nA01 40 1 2\nEND_DATA\n");
  EXPECT_THAT(test::error_message<DataError>([&] { ChartReference::load(dir / "twice.cie"); }),
              HasSubstr("patch 'A01' appears twice"));
  test::write_text(dir / "rgb.cie", "CGATS.17\nNUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_ID RGB_R RGB_G RGB_B\n"
                                    "END_DATA_FORMAT\nNUMBER_OF_SETS 1\nBEGIN_DATA\nA01 1 2 3\nEND_DATA\n");
  EXPECT_THAT(test::error_message<DataError>([&] { ChartReference::load(dir / "rgb.cie"); }),
              HasSubstr("neither LAB_L LAB_A LAB_B nor XYZ_X XYZ_Y XYZ_Z"));
}

TEST(ColourFit, TheMatrixOfANoiselessLinearCameraIsExactAndWhiteBalancesToD65) {
  const ChartReference ref = ChartReference::load(colorchecker());
  const ColourCalibration cal = fit_colour(ref, shoot(ref, 3.7), {});
  EXPECT_EQ(cal.patches_used, 24);
  EXPECT_LT(cal.mean_de00, 1e-3);
  EXPECT_LT(cal.max_de00, 1e-3);
  // The matrix is the inverse of the camera's mix, scaled by the exposure, into XYZ.
  const Eigen::Matrix3d expected = colour::srgb_to_xyz_matrix() * camera_mix().inverse() / 3.7;
  EXPECT_LT((cal.matrix - expected).cwiseAbs().maxCoeff(), 1e-4 * expected.cwiseAbs().maxCoeff());
  // The camera value of a perfect white diffuser, and white-balanced values: (1,1,1) is D65 white.
  EXPECT_LT((cal.camera_white - 3.7 * camera_mix() * colour::Rgb::Ones()).norm(), 1e-6);
  EXPECT_LT((cal.to_srgb_balanced(colour::Rgb::Ones()) - colour::Rgb::Ones()).norm(), 1e-9);
  // A deep blue paint in linear sRGB comes back through the camera and the calibration.
  const colour::Rgb blue(0.02, 0.05, 0.35);
  EXPECT_LT((cal.to_srgb(3.7 * camera_mix() * blue) - blue).norm(), 1e-6);
  EXPECT_THAT(cal.describe(), HasSubstr("matrix model on 24 patches: CIEDE2000 mean 0.00"));
}

namespace {

double mean_square_de(const ColourCalibration& cal) {
  double s = 0.0;
  for (const PatchReport& p : cal.patches)
    if (p.used) s += p.de00 * p.de00;
  return s / cal.patches_used;
}

// The camera values whose root-polynomial-2 image under `m` (3x6) is each patch's XYZ: a
// camera no matrix describes exactly (Newton from the linear part's inverse).
std::vector<PatchMeasurement> root_polynomial_camera(const ChartReference& ref, const Eigen::MatrixXd& m) {
  std::vector<PatchMeasurement> out;
  const std::vector<colour::Xyz> xyz = ref.xyz_d65();
  const Eigen::Matrix3d lin = m.leftCols<3>();
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    colour::Rgb c = lin.inverse() * xyz[i];
    for (int it = 0; it < 50; ++it) {
      const colour::Xyz f = m * colour_terms(ColourModel::RootPolynomial2, c) - xyz[i];
      Eigen::Matrix3d J;
      for (int j = 0; j < 3; ++j) {
        colour::Rgb d = c;
        d[j] += 1e-8;
        J.col(j) = (m * colour_terms(ColourModel::RootPolynomial2, d) - xyz[i] - f) / 1e-8;
      }
      c -= J.inverse() * f;
    }
    out.push_back({ref.patches[i], c, colour::Rgb::Zero(), 400, false});
  }
  return out;
}

}  // namespace

TEST(ColourFit, PatchMeansWithTwoPerMilleNoiseStayWithinTheChartTargets) {
  // 0.2 % per channel: the standard error of a patch mean of 400 pixels with 4 % noise each.
  const ChartReference ref = ChartReference::load(colorchecker());
  const ColourCalibration cal = fit_colour(ref, shoot(ref, 0.8, 0.002), {});
  std::printf("chart, 0.2 %% noise, matrix: %s\n", cal.describe().c_str());
  // The chart targets on the noisy simulator: mean <= 0.5, max <= 1.5.
  EXPECT_LT(cal.mean_de00, 0.5);
  EXPECT_LT(cal.max_de00, 1.5);
  EXPECT_GT(cal.mean_de00, 0.0);
  // The refinement minimises the mean of dE00^2: never worse on it than the linear start.
  ColourFitOptions linear;
  linear.refine_de00 = false;
  const ColourCalibration start = fit_colour(ref, shoot(ref, 0.8, 0.002), linear);
  EXPECT_LT(mean_square_de(cal), mean_square_de(start));
}

TEST(ColourFit, RootPolynomialCapturesWhatNoMatrixCanAndIsExposureInvariant) {
  const ChartReference ref = ChartReference::load(colorchecker());
  Eigen::MatrixXd truth(3, 6);
  truth.leftCols<3>() = colour::srgb_to_xyz_matrix() * camera_mix().inverse();
  truth.rightCols<3>() << 0.20, -0.10, 0.05,  //
      0.05, 0.10, -0.08,                      //
      -0.06, 0.15, 0.02;
  const std::vector<PatchMeasurement> shot = root_polynomial_camera(ref, truth);
  for (const PatchMeasurement& p : shot) ASSERT_TRUE((p.rgb.array() > 0).all()) << p.name;
  ColourFitOptions rp2;
  rp2.model = ColourModel::RootPolynomial2;
  const ColourCalibration matrix = fit_colour(ref, shot, {});
  const ColourCalibration root = fit_colour(ref, shot, rp2);
  EXPECT_GT(matrix.mean_de00, 0.3);
  EXPECT_LT(root.mean_de00, 1e-3);
  EXPECT_LT((root.matrix - truth).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_EQ(colour_terms(ColourModel::RootPolynomial3, colour::Rgb(1, 2, 3)).size(), 13);
  // k rgb -> k XYZ.
  const colour::Rgb c(0.3, 0.5, 0.2);
  EXPECT_LT((root.to_xyz(2.5 * c) - 2.5 * root.to_xyz(c)).norm(), 1e-12);
  // White balancing holds for the root polynomial too (camera_white found by Gauss-Newton).
  EXPECT_LT((root.to_xyz_balanced(colour::Rgb::Ones()) - colour::d65()).norm(), 1e-9);
}

TEST(ColourFit, ClippedAndDarkPatchesAreLeftOutAndTooFewIsAnErrorSayingWhy) {
  const ChartReference ref = ChartReference::load(colorchecker());
  std::vector<PatchMeasurement> shot = shoot(ref, 1.0);
  shot[18].clipped = true;                // the white patch
  shot[23].rgb = colour::Rgb::Zero();     // black, lost in the dark frame
  const ColourCalibration cal = fit_colour(ref, shot, {});
  EXPECT_EQ(cal.patches_used, 22);
  EXPECT_FALSE(cal.patches[18].used);
  EXPECT_EQ(cal.patches[18].why_not, "clipped");
  EXPECT_EQ(cal.patches[23].why_not, "too dark");
  EXPECT_LT(cal.mean_de00, 1e-3);

  std::vector<PatchMeasurement> few(shot.begin(), shot.begin() + 10);
  for (int i = 0; i < 3; ++i) few[static_cast<std::size_t>(i)].clipped = true;
  EXPECT_THAT(test::error_message<CalibrationError>([&] { fit_colour(ref, few, {}); }),
              HasSubstr("7 of the chart's 24 patches are usable (3 clipped, 0 too dark, 14 not measured); the matrix "
                        "model needs at least 9"));
  shot[0].name = "Z99";
  EXPECT_THAT(test::error_message<DataError>([&] { fit_colour(ref, shot, {}); }),
              HasSubstr("measured patch 'Z99' is not in the reference"));
}

TEST(ColourFit, TheCalibrationFileRoundTrips) {
  const ChartReference ref = ChartReference::load(colorchecker());
  ColourFitOptions rp2;
  rp2.model = ColourModel::RootPolynomial2;
  const ColourCalibration cal = fit_colour(ref, shoot(ref, 2.0, 0.003), rp2);
  test::TempDir dir;
  cal.save(dir / kColourFile);
  const ColourCalibration back = ColourCalibration::load(dir / kColourFile);
  EXPECT_EQ(back.model, ColourModel::RootPolynomial2);
  EXPECT_EQ(back.patches.size(), 24u);
  EXPECT_NEAR(back.mean_de00, cal.mean_de00, 1e-12);
  EXPECT_EQ(back.worst_patch, cal.worst_patch);
  const colour::Rgb c(0.4, 0.1, 0.7);
  EXPECT_LT((back.to_srgb(c) - cal.to_srgb(c)).norm(), 1e-12);
  Json j = cal.to_json();
  j["matrix"] = Json::array({Json::array({1, 2, 3})});
  EXPECT_THAT(test::error_message<DataError>([&] { ColourCalibration::from_json(j, "colour.json"); }),
              HasSubstr("colour.json: key 'matrix' must be 3x6 finite numbers for the root-polynomial-2 model"));
  j = cal.to_json();
  j["model"] = "cubic";
  EXPECT_THAT(test::error_message<DataError>([&] { ColourCalibration::from_json(j, "colour.json"); }),
              HasSubstr("unknown colour model 'cubic' (expected matrix, root-polynomial-2 or root-polynomial-3)"));
}

TEST(ColourCheck, TheRigCheckJudgesColourJsonAgainstItsTolerances) {
  const ChartReference ref = ChartReference::load(colorchecker());
  ColourCalibration cal = fit_colour(ref, shoot(ref, 0.8, 0.002), {});
  cal.provenance = Provenance::make("colour", {});
  test::TempDir dir;
  cal.save(dir / kColourFile);
  RigConfig rig = RigConfig::load(test::source_dir() / "examples" / "rig-sim.toml");
  rig.calibration_dir = dir.path();
  const RigCalibration loaded = RigCalibration::load(rig);
  ASSERT_TRUE(loaded.colour());
  CheckReport report = run_checks(rig, loaded);
  const CheckItem* mean = report.find("colour.mean_de00");
  ASSERT_NE(mean, nullptr);
  EXPECT_TRUE(mean->pass);
  EXPECT_NEAR(mean->value, cal.mean_de00, 1e-12);
  EXPECT_DOUBLE_EQ(mean->tolerance, 1.0);  // the default of [tolerances] colour_mean_de00
  EXPECT_TRUE(report.find("colour.max_de00")->pass);
  EXPECT_TRUE(report.find("colour.age_days")->pass);
  // A tighter tolerance than the chart reached: the check fails and says what to do.
  rig.tolerances.colour_mean_de00 = 0.01;
  report = run_checks(rig, loaded);
  EXPECT_FALSE(report.find("colour.mean_de00")->pass);
  EXPECT_THAT(report.find("colour.mean_de00")->action, HasSubstr("paintlab calibrate colour --rig rig-sim.toml"));
  EXPECT_THAT(report.table(), HasSubstr("colour.mean_de00"));
  // Without colour.json there is no colour check (a monochrome rig).
  std::filesystem::remove(dir / kColourFile);
  EXPECT_EQ(run_checks(rig, RigCalibration::load(rig)).find("colour.mean_de00"), nullptr);
}
