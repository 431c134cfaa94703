// The device factory (app/src/rig_devices.h) on a simulated rig: the real drivers talk
// Modbus TCP and GigE Vision on 127.0.0.1 to the simulated peers, whose world renders the
// sphere at the table angle the controller reached, lit by the LED SimLight switched.
#include <gtest/gtest.h>

#include <cmath>

#include "paintlab/core/rig.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "rig_devices.h"
#include "sim_rigs.h"
#include "test_util.h"

namespace paintlab {
namespace {

// A small simulated rig (320 x 240 px) so that rendering stays fast.
std::string small_sim_rig(const std::string& turntable_extra = "") {
  test::SimRigSpec s;
  s.name = "small-sim";
  s.turntable_extra = "speed_deg_s = 60\naccel_deg_s2 = 240\n" + turntable_extra;
  s.focal_length_mm = 12;
  s.camera_height_m = 0.0;
  s.positions = 181;
  s.step_deg = 1;
  s.settle_s = 0.5;
  s.dark_frames = std::nullopt;
  s.exposures_ms = "[1, 10]";
  s.extra = "[sim]\nseed = 7\n";
  return test::sim_rig_toml(s);
}

// Mean of a square patch.
double patch_mean(const Image<std::uint16_t>& img, int cx, int cy, int r) {
  double s = 0;
  int n = 0;
  for (int y = cy - r; y <= cy + r; ++y)
    for (int x = cx - r; x <= cx + r; ++x) {
      s += img.at(x, y);
      ++n;
    }
  return s / n;
}

TEST(RigDevices, SimulatedRigThroughTheRealDrivers) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", small_sim_rig());
  RigConfig rig = RigConfig::load(dir / "rig.toml");
  app::RigDevices d = app::open_rig_devices(rig);
  ASSERT_TRUE(d.turntable && d.light && d.camera && d.clock && d.sim);
  EXPECT_THAT(d.turntable->id(), ::testing::HasSubstr("modbus-tcp 127.0.0.1:"));
  EXPECT_EQ(d.camera->id(), "camera aravis 127.0.0.1");
  EXPECT_DOUBLE_EQ(d.camera->readout_s(), d.sim->world().config().sensor.readout_s);

  const double t0 = d.clock->now_s();
  ASSERT_TRUE(d.turntable->move_to(30.0));
  auto a = d.turntable->wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_NEAR(*a, 30.0, 1e-9);
  const double moved = d.clock->now_s() - t0;
  EXPECT_GE(moved, d.turntable->move_time_s(0.0, 30.0) - 1e-9);

  auto e = d.camera->set_exposure(0.05);
  ASSERT_TRUE(e);
  ASSERT_TRUE(d.light->off());
  auto dark = d.camera->capture(20.0);
  ASSERT_TRUE(dark) << dark.error().what();
  ASSERT_TRUE(d.light->on());
  const double t1 = d.clock->now_s();
  auto lit = d.camera->capture(20.0);
  ASSERT_TRUE(lit) << lit.error().what();
  // Exposure and readout took their time on the rig's (virtual) clock.
  EXPECT_GE(d.clock->now_s() - t1, *e + d.sim->world().config().sensor.readout_s - 1e-9);
  EXPECT_NEAR(d.sim->world().table_angle_deg(), 30.0, 1e-9);

  // The centre of the image sees the sphere lit from 30 deg: far above the dark frame,
  // and equal to the sim's own prediction for this exposure and gain.
  const int cx = 160, cy = 120;
  double lit_mean = patch_mean(lit->pixels, cx, cy, 2);
  double dark_mean = patch_mean(dark->pixels, cx, cy, 2);
  EXPECT_GT(lit_mean, dark_mean + 1000.0);
  sim::SimWorld& w = d.sim->world();
  ImageF radiance = w.render_at(30.0, true);
  const auto& sp = w.config().sensor;
  const double to16 = std::ldexp(1.0, 16 - sp.adc_bits);
  double predicted = 0;
  for (int y = cy - 2; y <= cy + 2; ++y)
    for (int x = cx - 2; x <= cx + 2; ++x)
      predicted += w.sensor().expected_raw(radiance.at(x, y), x, y, lit->meta.exposure_s, lit->meta.gain_db) * to16;
  predicted /= 25;
  EXPECT_NEAR(lit_mean, predicted, 0.03 * predicted);
}

TEST(RigDevices, SimulatedTurntableOverRtu) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", small_sim_rig("transport = \"rtu\"\n"));
  RigConfig rig = RigConfig::load(dir / "rig.toml");
  app::OpenDevicesOptions o;
  o.camera = false;
  app::RigDevices d = app::open_rig_devices(rig, o);
  ASSERT_TRUE(d.turntable);
  EXPECT_FALSE(d.camera);
  EXPECT_THAT(d.turntable->id(), ::testing::HasSubstr("modbus-rtu /dev/pts/"));
  ASSERT_TRUE(d.turntable->move_to(-20.0));
  auto a = d.turntable->wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_NEAR(*a, -20.0, 1e-9);
}

TEST(RigDevices, BadDeviceKeyIsAConfigErrorBeforeAnythingStarts) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", small_sim_rig("sped_deg_s = 3\n"));
  RigConfig rig = RigConfig::load(dir / "rig.toml");
  EXPECT_THROW(app::open_rig_devices(rig), ConfigError);
}

}  // namespace
}  // namespace paintlab
