#include <gtest/gtest.h>

#include <algorithm>

#include "paintlab/core/image_io.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {

// A small simulated rig (320 x 240, 12 mm lens) so the commands run fast.
std::string rig_text() {
  test::SimRigSpec s;
  s.name = "small-sim";
  s.focal_length_mm = 12;
  s.positions = 181;
  s.step_deg = 1;
  s.exposures_ms = "[1, 10, 100]";
  s.extra = R"([sim]
seed = 5
[sim.camera]
dist = [-0.2, 0.1, 0.0, 0.0, 0.0]
psf_sigma_px = 0.5
)";
  return test::sim_rig_toml(s);
}

}  // namespace

TEST(SimCli, RendersRadianceAndRawFrames) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", rig_text());
  std::string paint = (test::source_dir() / "paints/silver-metallic.toml").string();
  auto r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --paint " + paint +
                              " --angle 30 --out " + (dir / "sphere.exr").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("sphere painted 'silver-metallic' at table angle 30 deg"));
  ExrImage exr = read_exr(dir / "sphere.exr");
  ASSERT_EQ(exr.width, 320);
  ASSERT_EQ(exr.height, 240);
  const ImageF& y = exr.plane("Y");
  float peak = *std::max_element(y.values().begin(), y.values().end());
  EXPECT_GT(peak, 0.01f);
  EXPECT_GE(*std::min_element(y.values().begin(), y.values().end()), 0.0f);

  r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --paint " + paint +
                         " --angle 30 --exposure 20 --out " + (dir / "sphere.png").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  RawImage raw = read_raw_image(dir / "sphere.png");
  EXPECT_EQ(raw.bit_depth, 16);
  ASSERT_EQ(raw.pixels.width(), 320);
  // 12-bit ADC values MSB aligned in 16 bits: multiples of 16, the black level 64 * 16 in the dark.
  int odd = 0;
  for (std::uint16_t v : raw.pixels.values()) odd += v % 16 != 0;
  EXPECT_EQ(odd, 0);
  std::vector<std::uint16_t> sorted = raw.pixels.values();
  std::nth_element(sorted.begin(), sorted.begin() + 100, sorted.end());
  EXPECT_NEAR(sorted[100], 64 * 16, 20 * 16);

  for (const char* scene : {"chessboard", "charuco", "flat", "dark", "white"}) {
    r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --scene " + scene +
                           " --exposure 10 --rgb --out " + (dir / (std::string(scene) + ".exr")).string());
    ASSERT_EQ(r.exit_code, 0) << scene << ": " << r.err;
    EXPECT_EQ(read_exr(dir / (std::string(scene) + ".exr")).names.size(), 3u) << scene;
  }
}

TEST(SimCli, BadInputExitsWithTwo) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", rig_text() + "typo_key = 1\n");
  std::string paint = (test::source_dir() / "paints/silver-metallic.toml").string();
  auto r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --paint " + paint + " --out " +
                              (dir / "x.exr").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("rig.toml:40: key 'sim.camera.typo_key': unknown key"));
  test::write_text(dir / "rig.toml", rig_text());
  r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --paint " + paint + " --out " +
                         (dir / "x.jpg").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--out must end in .exr"));
  r = test::run_paintlab("sim render --rig " + (dir / "rig.toml").string() + " --out " + (dir / "x.exr").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--paint is required"));
  EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));
}
