#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/core/rig.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {
const std::string kMinimal = "name = \"r1\"\n" + test::kSimDevicesToml + R"([geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
camera_distance_m = 1.2
[plan]
angle_start_deg = 0
angle_stop_deg = 180
angle_step_deg = 1
exposures_ms = [0.25, 1, 4]
)";

std::string error_of(const std::string& text) {
  try {
    RigConfig::parse(ConfigTable::parse_string(text, "rig.toml"), "/lab/rig.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}
}  // namespace

TEST(Rig, ExamplesAreValid) {
  for (const char* name : {"rig-sim.toml", "rig-lab.toml"}) {
    RigConfig r = RigConfig::load(test::source_dir() / "examples" / name);
    EXPECT_EQ(r.plan.angles_deg().size(), 181u) << name;
    ASSERT_EQ(r.plan.exposures_s.size(), 16u) << name;
    EXPECT_NEAR(r.plan.exposures_s.front(), 0.25e-3, 1e-12);
    EXPECT_NEAR(r.plan.exposures_s.back(), 0.328, 1e-12);
  }
  EXPECT_TRUE(RigConfig::load(test::source_dir() / "examples/rig-sim.toml").all_simulated());
  RigConfig lab = RigConfig::load(test::source_dir() / "examples/rig-lab.toml");
  EXPECT_EQ(lab.turntable.kind, "modbus-tcp");
  EXPECT_EQ(lab.light.kind, "gpiod");
  EXPECT_EQ(lab.camera.kind, "aravis");
  EXPECT_EQ(lab.calibration_dir, test::source_dir() / "examples/calib");
}

TEST(Rig, MinimalParses) {
  RigConfig r = RigConfig::parse(ConfigTable::parse_string(kMinimal, "rig.toml"), "/lab/rig.toml");
  EXPECT_EQ(r.calibration_dir, std::filesystem::path("/lab/calib"));
  EXPECT_EQ(r.plan.exposures_s.size(), 3u);
  EXPECT_DOUBLE_EQ(r.geometry.arm_height_m, 0.0);
}

// What `paintlab rig validate` prints, in the units a technician reads.
TEST(Rig, DescribeGivesDevicesGeometryInMmAndTheBracketInMs) {
  const RigConfig r = RigConfig::parse(ConfigTable::parse_string(kMinimal, "rig.toml"), "/lab/rig.toml");
  const std::string d = r.describe();
  EXPECT_THAT(d, HasSubstr("rig 'r1' (/lab/rig.toml): valid\n"));
  EXPECT_THAT(d, HasSubstr("calibration folder  /lab/calib\n"));
  EXPECT_THAT(d, HasSubstr("turntable           sim\n"));
  EXPECT_THAT(d, HasSubstr("sphere radius       40.00 mm\n"));
  EXPECT_THAT(d, HasSubstr("arm                 radius 600.0 mm, height 0.0 mm"));
  EXPECT_THAT(d, HasSubstr("1200.0 mm away"));
  EXPECT_THAT(d, HasSubstr("181 positions, 0 to 180 deg in 1 deg steps\n"));
  EXPECT_THAT(d, HasSubstr("3 exposures, 0.25 ms to 4 ms\n"));
  EXPECT_THAT(d, ::testing::Not(HasSubstr("[sim]")));
}

TEST(Rig, RejectsUnknownKey) {
  std::string t = std::string(kMinimal) + "colour = 3\n";
  EXPECT_THAT(error_of(t), HasSubstr("key 'plan.colour': unknown key in [plan]"));
}

TEST(Rig, RejectsBadDeviceKind) {
  std::string t = kMinimal;
  t.replace(t.find("kind = \"sim\"\n[devices.light]"), 12, "kind = \"usb\"");
  EXPECT_THAT(error_of(t), HasSubstr("rig.toml:3: key 'devices.turntable.kind': \"usb\" is not one of"));
}

TEST(Rig, RejectsOutOfRangeAndWrongType) {
  std::string t = kMinimal;
  t.replace(t.find("0.04"), 4, "-0.04");
  EXPECT_THAT(error_of(t), HasSubstr("rig.toml:9: key 'geometry.sphere_radius_m': must be in (0.001, 1)"));
  t = kMinimal;
  t.replace(t.find("angle_step_deg = 1"), 18, "angle_step_deg = \"1\"");
  EXPECT_THAT(error_of(t), HasSubstr("key 'plan.angle_step_deg': expected a number, got a string"));
}

TEST(Rig, RejectsNoAnglesAndBadBracket) {
  std::string t = kMinimal;
  t.replace(t.find("angle_stop_deg = 180"), 20, "angle_stop_deg = -5");
  EXPECT_THAT(error_of(t), HasSubstr("key 'plan.angle_stop_deg': must not be smaller than angle_start_deg"));
  t = kMinimal;
  t.replace(t.find("[0.25, 1, 4]"), 12, "[1, 0.25]");
  EXPECT_THAT(error_of(t), HasSubstr("strictly ascending"));
  t = kMinimal;
  t.replace(t.find("exposures_ms = [0.25, 1, 4]"), 27, "");
  EXPECT_THAT(error_of(t), HasSubstr("exactly one of the two"));
}

TEST(Rig, GeometricBracket) {
  auto b = geometric_bracket(0.25, 328, 16);
  ASSERT_EQ(b.size(), 16u);
  for (size_t i = 1; i < b.size(); ++i) EXPECT_NEAR(b[i] / b[i - 1], b[1] / b[0], 1e-9);
  EXPECT_DOUBLE_EQ(b.back(), 328);
}

// Issue 13: a step of 1e-7 deg passed as 1.8 billion positions (43 s, 16.8 GB), 1e-9 ran
// out of memory, 1e-300 gave "0 positions". Each is refused with the reason and the key.
TEST(Rig, PlanBoundsTheStepThePositionsAndTheSweepTime) {
  auto with = [](const std::string& from, const std::string& to) {
    std::string t = kMinimal;
    t.replace(t.find(from), from.size(), to);
    return t;
  };
  for (const char* step : {"1e-7", "1e-9", "1e-300", "0.0005"})
    EXPECT_THAT(error_of(with("angle_step_deg = 1", std::string("angle_step_deg = ") + step)),
                HasSubstr("key 'plan.angle_step_deg': must be at least 0.001 deg"))
        << step;
  const std::string many = error_of(with("angle_step_deg = 1", "angle_step_deg = 0.002"));
  EXPECT_THAT(many, HasSubstr("key 'plan.angle_step_deg': gives 90001 light positions from 0 to 180 deg"));
  EXPECT_THAT(many, HasSubstr("a plan holds at most 36001 (a step of at least 0.005 deg over this span)"));
  // 181 positions x (0.5 s + exposures of 900, 910 and 920 s), plus 4 dark frames of each: 140 h.
  EXPECT_THAT(error_of(with("exposures_ms = [0.25, 1, 4]", "exposures_ms = [9e5, 9.1e5, 9.2e5]")),
              HasSubstr("key 'plan.exposures_ms': the sweep would take at least 140 h"));
  // The largest plans allowed still parse: 36001 positions, and 0.001 deg steps over 36 deg.
  for (const auto& ok : {with("angle_stop_deg = 180\nangle_step_deg = 1", "angle_stop_deg = 360\nangle_step_deg = 0.01"),
                         with("angle_stop_deg = 180\nangle_step_deg = 1", "angle_stop_deg = 36\nangle_step_deg = 0.001")}) {
    const RigConfig r = RigConfig::parse(ConfigTable::parse_string(ok, "rig.toml"), "/lab/rig.toml");
    EXPECT_EQ(r.plan.angles_deg().size(), 36001u);
  }
}
