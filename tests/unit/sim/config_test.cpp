#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/world.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {

const std::string kRig = "name = \"r1\"\n" + test::kSimDevicesToml + R"([geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
camera_distance_m = 1.2
camera_height_m = 0.05
image_width_px = 320
image_height_px = 240
[plan]
exposures_ms = [0.25, 1, 4]
)";

sim::SimConfig parse(const std::string& sim_part) {
  RigConfig rig = RigConfig::parse(ConfigTable::parse_string(kRig + sim_part, "rig.toml"), "/lab/rig.toml");
  return sim::SimConfig::from_rig(rig);
}

std::string error_of(const std::string& sim_part) {
  try {
    parse(sim_part);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(SimConfig, DefaultsFollowTheNominalGeometry) {
  sim::SimConfig c = parse("");
  EXPECT_EQ(c.camera.width_px, 320);
  EXPECT_NEAR(c.camera.fx_px, 0.05 / 6.45e-6, 1e-6);
  EXPECT_DOUBLE_EQ(c.camera.cx_px, 159.5);
  EXPECT_DOUBLE_EQ(c.camera.cy_px, 119.5);
  EXPECT_NEAR((c.camera.position_rig_m - Vec3(std::sqrt(1.44 - 0.0025), 0, 0.05)).norm(), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.led.arm_radius_m, 0.6);
  EXPECT_DOUBLE_EQ(c.sphere.radius_m, 0.04);
  EXPECT_EQ(c.sensor.response_poly, std::vector<double>{1.0});
  EXPECT_NO_THROW(c.check());
  // The camera looks at the rig origin: it projects to the principal point.
  sim::SimWorld world(c);
  Vec2 px = world.camera().project_rig(Vec3::Zero());
  EXPECT_NEAR(px.x(), 159.5, 1e-9);
  EXPECT_NEAR(px.y(), 119.5, 1e-9);
}

TEST(SimConfig, ExampleRigTruthDiffersFromNominal) {
  RigConfig rig = RigConfig::load(test::source_dir() / "examples/rig-sim.toml");
  sim::SimConfig c = sim::SimConfig::from_rig(rig);
  EXPECT_NE(c.camera.fx_px, 0.05 / 6.45e-6);
  EXPECT_NE(c.camera.dist[0], 0.0);
  EXPECT_NE(c.led.arm_radius_m, rig.geometry.arm_radius_m);
  EXPECT_NE(c.sphere.centre_rig_m.norm(), 0.0);
  EXPECT_EQ(c.sensor.response_poly.size(), 3u);
  EXPECT_NEAR(c.camera.fx_px / (0.05 / 6.45e-6), 1.0, 0.01);  // slightly, not wildly
  sim::SimWorld world(c);                                       // and it is a consistent world
  EXPECT_GT(world.sphere_centre_cam().z(), 1.0);
}

TEST(SimConfig, ParsesEverySection) {
  sim::SimConfig c = parse(R"(
[sim]
seed = 7
flake_seed = 11
clock_speed = 50
[sim.camera]
fx_px = 7800
dist = [-0.1, 0.2, 0.001, -0.002, 0.01]
roll_deg = 0.5
mono_weights = [0.3, 0.6, 0.1]
rgb_matrix = [0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78]
rgb_gain = [0.55, 1.0, 0.7]
[sim.sensor]
adc_bits = 16
black_level_dn = 100
response = [1.2, -0.2]
[sim.led]
zero_deg = 0.5
color = [1.0, 0.9, 0.8]
[sim.sphere]
centre_m = [0.001, 0, -0.001]
[sim.scene]
felt_albedo = 0.03
[sim.render]
edge_samples = 8
interior_samples = 4
interior_tolerance = 0.01
sparkle_floor = 0.5
)");
  EXPECT_EQ(c.seed, 7u);
  EXPECT_EQ(c.flake_field_seed(), 11u);
  EXPECT_EQ(parse("[sim]\nseed = 7\n").flake_field_seed(), 7u);  // unset: the rig's seed
  EXPECT_DOUBLE_EQ(c.clock_speed, 50.0);
  EXPECT_DOUBLE_EQ(c.camera.fx_px, 7800.0);
  EXPECT_DOUBLE_EQ(c.camera.dist[4], 0.01);
  EXPECT_DOUBLE_EQ(c.camera.mono_weights[0], 0.3);
  EXPECT_DOUBLE_EQ(c.camera.rgb_matrix[1], 0.25);
  EXPECT_DOUBLE_EQ(c.camera.rgb_matrix[8], 0.78);
  EXPECT_DOUBLE_EQ(c.camera.rgb_gain[0], 0.55);
  EXPECT_EQ(c.sensor.adc_bits, 16);
  EXPECT_DOUBLE_EQ(c.sensor.adc_max_dn(), 65535.0);
  EXPECT_DOUBLE_EQ(c.led.color[2], 0.8);
  EXPECT_DOUBLE_EQ(c.sphere.centre_rig_m.z(), -0.001);
  EXPECT_DOUBLE_EQ(c.scene.felt_albedo, 0.03);
  EXPECT_EQ(c.render.edge_samples, 8);
  EXPECT_EQ(c.render.interior_samples, 4);
  EXPECT_DOUBLE_EQ(c.render.interior_tolerance, 0.01);
  EXPECT_DOUBLE_EQ(c.render.sparkle_floor, 0.5);
  // The conversion gain fills the ADC with the full well unless given.
  EXPECT_NEAR(c.sensor.gain0_dn_per_e() * c.sensor.full_well_e, 65535.0 - 100.0, 1e-6);
  Json j = c.to_json();
  EXPECT_EQ(j["sensor"]["adc_bits"], 16);
  EXPECT_EQ(j["camera"]["rgb_gain"][2], 0.7);
  EXPECT_EQ(j["render"]["interior_samples"], 4);
  EXPECT_EQ(j["flake_seed"], 11);
}

TEST(SimConfig, ErrorsNameFileLineAndKey) {
  // Unknown keys at the top of [sim] and inside a section.
  EXPECT_THAT(error_of("[sim]\nsede = 3\n"), HasSubstr("rig.toml:18: key 'sim.sede': unknown key"));
  EXPECT_THAT(error_of("[sim]\n[sim.camera]\nfocal_px = 3\n"), HasSubstr("rig.toml:19: key 'sim.camera.focal_px': unknown key"));
  // Ranges and types.
  EXPECT_THAT(error_of("[sim.sensor]\nqe = 1.5\n"), HasSubstr("rig.toml:18: key 'sim.sensor.qe': must be in (0, 1]"));
  EXPECT_THAT(error_of("[sim.sensor]\nadc_bits = 20\n"), HasSubstr("key 'sim.sensor.adc_bits': must be in [8, 16]"));
  EXPECT_THAT(error_of("[sim.camera]\ndist = [0.1, 0.2]\n"), HasSubstr("key 'sim.camera.dist': expected 5 values"));
  EXPECT_THAT(error_of("[sim]\nseed = \"x\"\n"), HasSubstr("key 'sim.seed': expected an integer"));
  EXPECT_THAT(error_of("[sim.render]\ninterior_samples = 0\n"),
              HasSubstr("rig.toml:18: key 'sim.render.interior_samples': must be in [1, 16]"));
  EXPECT_THAT(error_of("[sim.render]\ninterior_tolerance = 0\n"), HasSubstr("key 'sim.render.interior_tolerance': must be in (0, 1]"));
  // Rules across keys.
  EXPECT_THAT(error_of("[sim.sensor]\nresponse = [1.5, -0.4]\n"),
              HasSubstr("rig.toml:18: key 'sim.sensor.response': the coefficients must sum to 1"));
  EXPECT_THAT(error_of("[sim.sensor]\nresponse = [2.5, -1.5]\n"), HasSubstr("must increase on [0, 1]"));
  EXPECT_THAT(error_of("[sim.camera]\nmono_weights = [0.5, 0.5, 0.5]\n"), HasSubstr("must sum to 1"));
  EXPECT_THAT(error_of("[sim.camera]\nrgb_matrix = [1, 1, 0, 1, 1, 0, 0, 0, 1]\n"),
              HasSubstr("rig.toml:18: key 'sim.camera.rgb_matrix': the channel mix must be invertible"));
  EXPECT_THAT(error_of("[sim.camera]\nrgb_matrix = [1, 0, 0]\n"), HasSubstr("key 'sim.camera.rgb_matrix': expected 9 values"));
  EXPECT_THAT(error_of("[sim.camera]\nrgb_gain = [1, 0, 1]\n"), HasSubstr("key 'sim.camera.rgb_gain': element 1 must be in (0, 10] (got 0)"));
  EXPECT_THAT(error_of("[sim.led]\narm_radius_m = 0.03\n"),
              HasSubstr("rig.toml:18: key 'sim.led.arm_radius_m': the LED arm must pass outside the sphere"));
  EXPECT_THAT(error_of("[sim.scene]\ntable_depth_m = 0.02\n"),
              HasSubstr("key 'sim.scene.table_depth_m': the table top must lie below the sphere's bottom"));
}

TEST(SimConfig, CheckRejectsInconsistentCodeBuiltConfigs) {
  sim::SimConfig c = parse("");
  c.sensor.response_poly = {0.5};
  EXPECT_THROW(c.check(), DataError);
  c = parse("");
  c.render.sparkle_floor = 0;
  EXPECT_THROW(c.check(), DataError);
  c = parse("");
  c.camera.look_at_rig_m = Vec3(0, 2, 0);  // the camera looks away from the sphere
  EXPECT_THROW(sim::SimWorld{c}, DataError);
}
