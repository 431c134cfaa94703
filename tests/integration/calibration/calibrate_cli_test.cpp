// `paintlab calibrate intrinsics` on photos alone (DESIGN.md contract) and its usage errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "paintlab/core/json.h"
#include "sim_rigs.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;

namespace {
const fs::path kPhotos = "/usr/share/doc/opencv-doc/examples/data";
}

TEST(CalibrateCli, IntrinsicsOnPhotosAloneWritesCameraJson) {
  ASSERT_TRUE(fs::exists(kPhotos / "left01.jpg")) << "opencv-doc sample photos missing under " << kPhotos << " (scripts/setup.sh installs opencv-doc)";
  test::TempDir dir;
  std::string files;
  for (int i = 1; i <= 14; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "left%02d.jpg", i);
    if (fs::exists(kPhotos / name)) files += " " + (kPhotos / name).string();
  }
  auto r = test::run_paintlab("calibrate intrinsics --images" + files + " --board 9x6 --square 25 --out " +
                              (dir / "camera.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("intrinsics: 13 of 13 views, RMS 0.15"));
  Json j = read_json_file(dir / "camera.json");
  EXPECT_EQ(j["K"].size(), 3u);
  EXPECT_EQ(j["dist"].size(), 5u);
  EXPECT_EQ(j["image_size"][0], 640);
  EXPECT_LE(j["rms_px"].get<double>(), 0.25);
  EXPECT_EQ(j["provenance"]["inputs"].size(), 13u);
  EXPECT_EQ(j["provenance"]["inputs"][0]["sha256"].get<std::string>().size(), 64u);
}

TEST(CalibrateCli, UsageErrorsExitTwoAndSayWhat) {
  test::TempDir dir;
  auto r = test::run_paintlab("calibrate intrinsics --images " + (kPhotos / "left01.jpg").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("without --rig give --images FILES... and --out FILE"));
  r = test::run_paintlab("calibrate intrinsics --images " + (kPhotos / "left01.jpg").string() + " --board 9by6 --out " +
                         (dir / "c.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--board '9by6': expected COLSxROWS"));
  r = test::run_paintlab("calibrate intrinsics --images " + (dir / "nothing.png").string() + " --out " +
                         (dir / "c.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("no such file or folder"));
  EXPECT_FALSE(fs::exists(dir / "c.json"));
  r = test::run_paintlab("calibrate all --rig " + (dir / "rig.toml").string() + " --images " + dir.path().string() +
                         " --fix-k3 --free-k3");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("give --fix-k3 or --free-k3, not both"));
}

TEST(CalibrateCli, TooFewBoardsFailsWithTheDroppedViewsNamed) {
  ASSERT_TRUE(fs::exists(kPhotos / "left01.jpg")) << "opencv-doc sample photos missing under " << kPhotos << " (scripts/setup.sh installs opencv-doc)";
  test::TempDir dir;
  // Two photos and one that shows no chessboard (OpenCV's left.jpg is not a 9x6 board view).
  auto r = test::run_paintlab("calibrate intrinsics --images " + (kPhotos / "left01.jpg").string() + " " +
                              (kPhotos / "left02.jpg").string() + " --board 9x6 --square 25 --out " +
                              (dir / "c.json").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, ::testing::HasSubstr("only 2 usable chessboard views of 2 (at least 3 needed)"));
  EXPECT_FALSE(fs::exists(dir / "c.json"));
}

TEST(CheckCli, EmptyCalibrationFolderFailsWithTheCommandsToRunAndWritesCheckJson) {
  // Offline (no --capture): the files alone decide. A rig whose calibration folder is empty.
  test::TempDir dir;
  fs::copy_file(test::source_dir() / "examples" / "rig-sim.toml", dir / "rig.toml");
  auto r = test::run_paintlab("check --rig " + (dir / "rig.toml").string());
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("RIG NOT FIT TO MEASURE"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("run `paintlab calibrate intrinsics"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("run `paintlab calibrate light"));
  Json j = read_json_file(dir / "calib-sim" / "check.json");
  EXPECT_FALSE(j["passed"].get<bool>());
  ASSERT_TRUE(j["checks"].is_array());
  EXPECT_GE(j["checks"].size(), 7u);
  // --json prints the same report as JSON.
  r = test::run_paintlab("check --rig " + (dir / "rig.toml").string() + " --json");
  EXPECT_EQ(r.exit_code, 1);
  Json printed = Json::parse(r.out);
  EXPECT_FALSE(printed["passed"].get<bool>());
  // --report: the calibration folder's page, written though the check failed, saying what
  // fails and which files are missing (docs/reports.md).
  r = test::run_paintlab("check --rig " + (dir / "rig.toml").string() + " --report " + (dir / "check.html").string());
  EXPECT_EQ(r.exit_code, 1);
  std::ifstream in(dir / "check.html");
  const std::string page((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(page, ::testing::HasSubstr("id=\"check-verdict\">FAILED"));
  EXPECT_THAT(page, ::testing::HasSubstr("missing: run <code>paintlab calibrate light</code>"));
}

// A step whose prerequisites are missing stops before any device opens and names the files
// and the steps that make them (the procedure table, calibration/procedure.h).
TEST(CalibrateCli, AStepWithoutWhatItNeedsNamesTheFilesAndTheSteps) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", test::small_sim_rig());
  fs::create_directories(dir / "shots");
  auto r = test::run_paintlab("calibrate light --rig " + (dir / "rig.toml").string() + " --images " +
                              (dir / "shots").string());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("calibrate light needs what the calibration folder lacks"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("camera.json: run `paintlab calibrate intrinsics --rig"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("sphere.json: run `paintlab calibrate sphere --rig"));
  EXPECT_FALSE(fs::exists(dir / "calib" / "light.json"));
  // The help of each step comes from the same table.
  r = test::run_paintlab("calibrate scale --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, ::testing::HasSubstr("Absolute BRDF scale from the white reference sphere"));
}
