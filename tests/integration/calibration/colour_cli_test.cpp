// `paintlab sim render --scene colour-chart` and `paintlab calibrate colour` as a technician runs
// them: the chart rendered by the simulated rig, found, and the colour matrix written; bad
// input refused with exit 2 and nothing written.
#include <gtest/gtest.h>

#include <filesystem>

#include "paintlab/core/json.h"
#include "sim_rigs.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using ::testing::HasSubstr;

TEST(ColourCli, TheSimulatedChartCalibratesToColourJson) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", test::small_sim_rig(5, 10.0, 4, 800, 600));
  const std::string chart = (dir / "chart.exr").string();
  auto r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --scene colour-chart --rgb --out " + chart);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("6x4 colour chart of 40 mm patches, view 0"));
  r = test::run_paintlab("calibrate colour --images " + chart + " --out " + (dir / "colour.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("colour: matrix model on 24 patches: CIEDE2000 mean 0.0"));
  const Json j = read_json_file(dir / "colour.json");
  EXPECT_EQ(j["model"], "matrix");
  EXPECT_EQ(j["patches"].size(), 24u);
  // A noiseless render of the reference colours with the identity camera: exact.
  EXPECT_LT(j["mean_de00"].get<double>(), 0.05);
  EXPECT_LT(j["max_de00"].get<double>(), 0.2);
  EXPECT_EQ(j["provenance"]["kind"], "colour");
  EXPECT_EQ(j["provenance"]["inputs"].size(), 2u);  // the image and the reference file

  // With --rig it writes the rig's calibration folder; the root polynomial on request.
  r = test::run_paintlab("calibrate colour --images " + chart + " --rig " + (dir / "rig.toml").string() +
                         " --model root-polynomial-2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_json_file(dir / "calib" / "colour.json")["model"], "root-polynomial-2");
}

TEST(ColourCli, BadInputExitsTwoSayingWhatAndWritesNothing) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", test::small_sim_rig(5, 10.0, 4, 320, 240));
  const std::string out = (dir / "colour.json").string();
  // A monochrome image: no R, G, B.
  const std::string flat = (dir / "flat.exr").string();
  ASSERT_EQ(test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --scene flat --out " + flat).exit_code, 0);
  auto r = test::run_paintlab("calibrate colour --images " + flat + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("flat.exr: no channel R: the colour chart needs a linear RGB image"));
  // An RGB image without a chart: the job failed (exit 1), saying what to do.
  ASSERT_EQ(test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --scene flat --rgb --out " + flat)
                .exit_code,
            0);
  r = test::run_paintlab("calibrate colour --images " + flat + " --out " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no ColorChecker 24 found"));
  r = test::run_paintlab("calibrate colour --images " + flat + " --out " + out + " --model cubic");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--model: unknown colour model 'cubic' (expected matrix, root-polynomial-2 or root-polynomial-3)"));
  r = test::run_paintlab("calibrate colour --images " + flat + " --out " + out + " --reference " + (dir / "none.cie").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("none.cie"));
  r = test::run_paintlab("calibrate colour --images " + flat + " --out " + flat);
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("calibrate colour --images " + flat);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("give --rig R (writes its calibration folder's colour.json) or --out FILE"));
  EXPECT_FALSE(fs::exists(out));
}

// On a simulated rig with a Bayer camera whose channels are not sRGB's and a warm LED: the
// dark frame first (the chart's values must be black-subtracted), then the chart photographed
// and calibrated; the monochrome rig is told it cannot.
TEST(ColourCli, TheChartPhotographedThroughTheRigsBayerCameraMeetsTheTargets) {
  test::TempDir dir;
  test::SimRigSpec spec;
  spec.pixel_format = "BayerRG16";
  spec.width = 800;
  spec.height = 600;
  spec.extra = "[sim]\nseed = 3\n[sim.camera]\nrgb_matrix = [0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78]\n"
               "rgb_gain = [0.6, 1.0, 0.8]\n[sim.led]\ncolor = [1.0, 0.9, 0.75]\n";
  test::write_text(dir / "rig.toml", test::sim_rig_toml(spec));
  const std::string rig = (dir / "rig.toml").string();
  auto r = test::run_paintlab("calibrate dark --rig " + rig + " --capture", 120);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = test::run_paintlab("calibrate colour --rig " + rig + " --capture", 120);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  std::printf("%s", r.out.c_str());
  const Json j = read_json_file(dir / "calib" / "colour.json");
  // The chart targets on the noisy simulator.
  EXPECT_LT(j["mean_de00"].get<double>(), 0.5);
  EXPECT_LT(j["max_de00"].get<double>(), 1.5);
  EXPECT_THAT(j["provenance"]["inputs"][0]["path"].get<std::string>(), HasSubstr("chart.png"));

  test::SimRigSpec mono = spec;
  mono.pixel_format = "Mono16";
  test::write_text(dir / "mono.toml", test::sim_rig_toml(mono));
  r = test::run_paintlab("calibrate colour --rig " + (dir / "mono.toml").string() + " --capture", 120);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("a colour chart needs a colour camera"));
}
