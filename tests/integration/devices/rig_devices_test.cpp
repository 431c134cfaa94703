// The device factory (app/src/rig_devices.h) on a simulated rig: the real drivers talk
// Modbus TCP and GigE Vision on 127.0.0.1 to the simulated peers, whose world renders the
// sphere at the table angle the controller reached, lit by the LED SimLight switched.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

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

TEST(RigDevices, TheSimulatedFilterWheelThroughTheSerialDriverColoursTheMonochromeFrames) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml",
                   small_sim_rig() + "[devices.filter_wheel]\nkind = \"sim\"\nslot_r = 2\nslot_g = 4\nslot_b = 6\n");
  RigConfig rig = RigConfig::load(dir / "rig.toml");
  app::RigDevices d = app::open_rig_devices(rig);
  ASSERT_TRUE(d.filter_wheel && d.sim && d.sim->filter_wheel());
  EXPECT_THAT(d.filter_wheel->id(), ::testing::HasSubstr("/dev/pts/"));
  auto idn = d.filter_wheel->identify();
  ASSERT_TRUE(idn) << idn.error().what();
  EXPECT_THAT(*idn, ::testing::HasSubstr("FW102C"));
  EXPECT_EQ(*d.filter_wheel->slot_count(), 6);

  ASSERT_TRUE(d.turntable->move_to(30.0));
  ASSERT_TRUE(d.turntable->wait_settled(10.0));
  ASSERT_TRUE(d.light->on());
  ASSERT_TRUE(d.camera->set_exposure(0.05));
  sim::SimWorld& w = d.sim->world();
  sim::RenderOptions rgb;
  rgb.mono = false;
  const ImageF scene = w.render_at(30.0, true, rgb);
  const auto& wt = w.config().camera.mono_weights;
  const auto& f = w.config().filters;
  const auto& sp = w.config().sensor;
  const double to16 = std::ldexp(1.0, 16 - sp.adc_bits);
  const int cx = 160, cy = 120;
  // Slot -> what the monochrome sensor weighs the scene's R, G, B with behind it.
  const std::vector<std::pair<int, std::array<double, 3>>> slots = {
      {2, {wt[0] * f.red[0], wt[1] * f.red[1], wt[2] * f.red[2]}},
      {4, {wt[0] * f.green[0], wt[1] * f.green[1], wt[2] * f.green[2]}},
      {6, {wt[0] * f.blue[0], wt[1] * f.blue[1], wt[2] * f.blue[2]}},
      {1, wt}};  // an empty slot
  for (const auto& [slot, mix] : slots) {
    SCOPED_TRACE(slot);
    const double t0 = d.clock->now_s();
    ASSERT_TRUE(d.filter_wheel->move_to(slot));
    EXPECT_GT(d.clock->now_s(), t0);  // the move and the settle took time on the rig's clock
    EXPECT_EQ(d.sim->filter_wheel()->position(), slot);
    auto frame = d.camera->capture(20.0);
    ASSERT_TRUE(frame) << frame.error().what();
    double predicted = 0;
    for (int y = cy - 2; y <= cy + 2; ++y)
      for (int x = cx - 2; x <= cx + 2; ++x) {
        const double L = mix[0] * scene.at(x, y, 0) + mix[1] * scene.at(x, y, 1) + mix[2] * scene.at(x, y, 2);
        predicted += w.sensor().expected_raw(L, x, y, frame->meta.exposure_s, frame->meta.gain_db) * to16;
      }
    predicted /= 25;
    EXPECT_NEAR(patch_mean(frame->pixels, cx, cy, 2), predicted, 0.03 * predicted);
  }
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
