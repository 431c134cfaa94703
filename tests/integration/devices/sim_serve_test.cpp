// `paintlab sim serve` and `paintlab devices` as a person (or a second process) uses them:
// endpoints printed when ready, the real drivers and Aravis' own arv-tool-0.8 talking to
// the served peers, a clean stop on SIGTERM.
#include <gtest/gtest.h>

#include <csignal>

#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/sim/peers/sim_filter_wheel.h"
#include "process_util.h"
#include "test_util.h"

namespace paintlab {
namespace {

std::string paintlab_exe() { return (test::binary_dir() / "app" / "paintlab").string(); }

const char* kRig = R"(name = "serve-sim"
[devices.turntable]
kind = "sim"
speed_deg_s = 90
accel_deg_s2 = 900
[devices.light]
kind = "sim"
[devices.camera]
kind = "sim"
pixel_format = "Mono12"
[geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
camera_distance_m = 1.2
focal_length_mm = 12
image_width_px = 320
image_height_px = 240
[plan]
exposures_ms = [1]
)";

TEST(SimServe, ServesModbusAndGigeUntilSigterm) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", kRig);
  test::Process serve({paintlab_exe(), "sim", "serve", "--rig", (dir / "rig.toml").string(), "--modbus-port", "0"});
  std::string seen;
  auto tcp = serve.wait_for("modbus-tcp 127.0.0.1:", 30.0, &seen);
  ASSERT_TRUE(tcp) << seen;
  auto rtu = serve.wait_for("modbus-rtu /dev/pts/", 10.0, &seen);
  ASSERT_TRUE(rtu) << seen;
  ASSERT_TRUE(serve.wait_for("gige 127.0.0.1", 10.0, &seen)) << seen;

  dev::ModbusTurntableConfig tc;
  tc.map = dev::builtin_register_map("oriental-az");
  tc.port = std::stoi(tcp->substr(tcp->rfind(':') + 1));
  tc.speed_deg_s = 90;
  tc.accel_deg_s2 = tc.decel_deg_s2 = 900;
  dev::ModbusTurntable table(tc);  // wall clock: the server runs on it too
  ASSERT_TRUE(table.move_to(45.0));
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_NEAR(*a, 45.0, 1e-9);
  dev::ModbusTurntableConfig rc = tc;
  rc.transport = dev::ModbusTurntableConfig::Transport::Rtu;
  rc.serial_device = rtu->substr(rtu->find("/dev/pts/"));
  rc.parity = 'N';
  dev::ModbusTurntable over_rtu(rc);
  auto b = over_rtu.angle_deg();
  ASSERT_TRUE(b) << b.error().what();
  EXPECT_NEAR(*b, 45.0, 1e-9);

  // Aravis' own tool sees the modern feature names.
  {
    test::Process tool({"arv-tool-0.8", "-a", "127.0.0.1", "features"});
    std::string out;
    while (auto line = tool.read_line(20.0)) out += *line + "\n";
    EXPECT_THAT(out, ::testing::HasSubstr("'ExposureTime'"));
    EXPECT_THAT(out, ::testing::HasSubstr("'Gain'"));
    EXPECT_THAT(out, ::testing::HasSubstr("'BlackLevel'"));
    EXPECT_THAT(out, ::testing::HasSubstr("'Mono12'"));
  }
  {
    dev::AravisCameraConfig cc;
    cc.id = "127.0.0.1";
    cc.pixel_format = dev::PixelFormat::Mono12;
    auto cam = dev::AravisCamera::open(cc);
    ASSERT_TRUE(cam) << cam.error().what();
    ASSERT_TRUE((*cam)->set_exposure(0.05));
    auto f = (*cam)->capture(20.0);
    ASSERT_TRUE(f) << f.error().what();
    EXPECT_EQ(f->pixels.width(), 320);
    // The LED is on while serving: the sphere in the centre is bright above the black level.
    EXPECT_GT(f->pixels.at(160, 120), 64 + 150);
    EXPECT_LE(f->pixels.at(160, 120), 4095);
  }

  serve.signal(SIGTERM);
  EXPECT_EQ(serve.wait_exit(15.0), 0);
}

TEST(DevicesCommand, SimulatedRigListsEveryKind) {
  auto r = test::run_paintlab("devices --rig '" + (test::source_dir() / "examples/rig-sim.toml").string() + "'", 60);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("camera  sim: simulated"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("table   sim: simulated"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("gpio    "));
  EXPECT_THAT(r.out, ::testing::HasSubstr("usb     "));
}

TEST(DevicesCommand, TheRigsSerialFilterWheelIsAskedWhoItIs) {
  // The simulated wheel on a pty pair stands in for a wheel on /dev/ttyUSB0: `paintlab devices`
  // (another process) opens it with the real driver.
  sim::SimFilterWheel wheel;
  test::TempDir dir;
  const std::string rig = (test::source_dir() / "examples/rig-sim.toml").string();
  std::string text = read_file(rig);
  text += "[devices.filter_wheel]\nkind = \"serial\"\nport = \"" + wheel.port() + "\"\nslot_b = 5\n";
  test::write_text(dir / "rig.toml", text);
  auto r = test::run_paintlab("devices --rig '" + (dir / "rig.toml").string() + "'", 60);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("wheel   filter wheel serial " + wheel.port() +
                                          ": THORLABS FW102C/FW212C Filter Wheel version 1.07 (paintlab sim), 6 slots; "
                                          "R, G, B filters in slots 1, 2, 5"));
  // No wheel at that port: reported, exit 1.
  text.replace(text.find(wheel.port()), wheel.port().size(), (dir / "ttyUSB9").string());
  test::write_text(dir / "rig.toml", text);
  r = test::run_paintlab("devices --rig '" + (dir / "rig.toml").string() + "'", 60);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("wheel   serial " + (dir / "ttyUSB9").string() + ": not reachable"));
}

TEST(DevicesCommand, UnreachableRealDevicesOnLoopbackAreReported) {
  test::TempDir dir;
  int port = test::free_tcp_port();
  test::write_text(dir / "rig.toml", std::string(R"(name = "lab-on-loopback"
[devices.turntable]
kind = "modbus-tcp"
host = "127.0.0.1"
port = )") + std::to_string(port) + R"(
response_timeout_ms = 200
[devices.light]
kind = "gpiod"
chip = "gpiochip0"
line = 17
[devices.camera]
kind = "aravis"
id = "127.0.0.1"
[geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
camera_distance_m = 1.2
[plan]
exposures_ms = [1]
)");
  auto r = test::run_paintlab("devices --rig '" + (dir / "rig.toml").string() + "'", 60);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("camera  aravis 127.0.0.1: not reachable"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("light   gpiod gpiochip0 line 17: chip not found"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("modbus-tcp 127.0.0.1:" + std::to_string(port) + " unit 1: not reachable"));
}

TEST(RigValidate, DeviceSectionKeysAreChecked) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", std::string(kRig) + "");
  auto ok = test::run_paintlab("rig validate '" + (dir / "rig.toml").string() + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  std::string bad = kRig;
  bad.replace(bad.find("speed_deg_s = 90"), 16, "speed_dg_s = 90");
  test::write_text(dir / "bad.toml", bad);
  auto r = test::run_paintlab("rig validate '" + (dir / "bad.toml").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("bad.toml:4: key 'devices.turntable.speed_dg_s'"));
}

}  // namespace
}  // namespace paintlab
