// The device sections of rig.toml: kind-specific keys, unknown keys rejected with file,
// line and key, the shipped example rigs valid.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/devices/device_config.h"
#include "test_util.h"

namespace paintlab {
namespace {

std::string rig_text(const std::string& devices) {
  return "name = \"t\"\n" + devices + R"(
[geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
camera_distance_m = 1.2
image_width_px = 640
image_height_px = 480
[plan]
exposures_ms = [1, 2]
)";
}

RigConfig parse(const std::string& devices) {
  auto root = ConfigTable::parse_string(rig_text(devices), "rig.toml");
  return RigConfig::parse(root, "/tmp/rig.toml");
}

TEST(DeviceConfig, ExampleRigsAreValid) {
  for (const char* f : {"examples/rig-lab.toml", "examples/rig-sim.toml"}) {
    RigConfig rig = RigConfig::load(test::source_dir() / f);
    EXPECT_NO_THROW(dev::validate_device_sections(rig)) << f;
  }
  RigConfig lab = RigConfig::load(test::source_dir() / "examples/rig-lab.toml");
  auto t = dev::turntable_config(lab.turntable);
  EXPECT_EQ(t.host, "192.168.10.20");
  EXPECT_EQ(t.map.name, "oriental-az");
  EXPECT_DOUBLE_EQ(t.response_timeout_s, 1.0);
  auto l = dev::gpiod_config(lab.light);
  EXPECT_EQ(l.line, 17u);
  EXPECT_DOUBLE_EQ(l.max_on_s, 60.0);
  auto c = dev::camera_config(lab.camera, lab.geometry);
  EXPECT_EQ(c.id, "192.168.10.30");
  EXPECT_EQ(c.packet_size, 8000);
  EXPECT_DOUBLE_EQ(c.frame_timeout_s, 2.0);
}

TEST(DeviceConfig, UnknownKeyNamesFileLineAndKey) {
  RigConfig rig = parse(R"(
[devices.turntable]
kind = "modbus-tcp"
host = "127.0.0.1"
respones_timeout_ms = 2000
[devices.light]
kind = "sim"
[devices.camera]
kind = "sim"
)");
  try {
    dev::validate_device_sections(rig);
    FAIL() << "misspelt key accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "rig.toml");
    EXPECT_EQ(e.line(), 6);
    EXPECT_EQ(e.key(), "devices.turntable.respones_timeout_ms");
  }
}

TEST(DeviceConfig, KindSpecificRules) {
  EXPECT_THROW(dev::validate_device_sections(parse(R"(
[devices.turntable]
kind = "modbus-rtu"
host = "127.0.0.1"
[devices.light]
kind = "sim"
[devices.camera]
kind = "sim"
)")),
               ConfigError);  // RTU needs device, has no host
  EXPECT_THROW(dev::validate_device_sections(parse(R"(
[devices.turntable]
kind = "sim"
[devices.light]
kind = "gpiod"
chip = "gpiochip0"
line = 4
max_on_s = -1
[devices.camera]
kind = "sim"
)")),
               ConfigError);
  EXPECT_THROW(dev::validate_device_sections(parse("\n" + test::kSimDevicesToml + "id = \"192.168.1.2\"\n")),
               ConfigError);  // a simulated camera has no address
  // The Bayer mosaics are taken (calibration handles them; the measurement refuses them until
  // the colour merge is built); RGB8, which neither the simulator serves nor the merge takes, is not.
  EXPECT_EQ(dev::camera_config(parse("\n" + test::kSimDevicesToml + "pixel_format = \"BayerGB12\"\n").camera, {})
                .pixel_format,
            dev::PixelFormat::BayerGB12);
  EXPECT_THAT(test::error_message<ConfigError>([] {
                dev::validate_device_sections(parse("\n" + test::kSimDevicesToml + "pixel_format = \"RGB8\"\n"));
              }),
              ::testing::AllOf(::testing::HasSubstr("devices.camera.pixel_format"), ::testing::HasSubstr("BayerRG16")));
  RigConfig ok = parse(R"(
[devices.turntable]
kind = "sim"
transport = "rtu"
wrap = true
[devices.light]
kind = "sim"
max_on_s = 5
[devices.camera]
kind = "sim"
pixel_format = "Mono12"
readout_ms = 20
)");
  ASSERT_NO_THROW(dev::validate_device_sections(ok));
  auto t = dev::turntable_config(ok.turntable);
  EXPECT_EQ(t.transport, dev::ModbusTurntableConfig::Transport::Rtu);
  EXPECT_TRUE(t.wrap);
  auto c = dev::camera_config(ok.camera, ok.geometry);
  EXPECT_EQ(c.id, "127.0.0.1");
  EXPECT_EQ(c.width_px, 640);
  EXPECT_EQ(c.pixel_format, dev::PixelFormat::Mono12);
  EXPECT_DOUBLE_EQ(c.readout_s, 0.020);
  EXPECT_DOUBLE_EQ(dev::sim_light_config(ok.light).max_on_s, 5.0);
}

TEST(PixelFormat, NamesAndDepths) {
  for (auto f : {dev::PixelFormat::Mono8, dev::PixelFormat::Mono12, dev::PixelFormat::Mono16})
    EXPECT_EQ(dev::pixel_format_from_string(dev::to_string(f)), f);
  EXPECT_EQ(dev::bit_depth(dev::PixelFormat::Mono12), 12);
  EXPECT_THROW(dev::pixel_format_from_string("YUV422"), DataError);
}

// [devices.filter_wheel]: a serial wheel with its port, a simulated one with its slot count,
// and the slot of each colour filter; every mistake names its key.
TEST(DeviceConfig, TheFilterWheelSectionGivesTheSlotOfEachColour) {
  RigConfig serial = parse(test::kSimDevicesToml + R"([devices.filter_wheel]
kind = "serial"
port = "/dev/ttyUSB0"
settle_ms = 250
slot_r = 2
slot_g = 4
slot_b = 6
)");
  ASSERT_TRUE(serial.filter_wheel);
  EXPECT_FALSE(serial.all_simulated());
  EXPECT_NO_THROW(dev::validate_device_sections(serial));
  const dev::FilterWheelSetup w = dev::filter_wheel_config(*serial.filter_wheel);
  EXPECT_EQ(w.kind, "serial");
  EXPECT_EQ(w.serial.port, "/dev/ttyUSB0");
  EXPECT_DOUBLE_EQ(w.serial.settle_s, 0.25);
  EXPECT_EQ(w.channel_slot, (std::array<int, 3>{2, 4, 6}));
  EXPECT_THAT(serial.describe(), ::testing::HasSubstr("filter wheel        serial\n"));
  EXPECT_EQ(serial.to_json()["devices"]["filter_wheel"]["kind"], "serial");

  RigConfig sim = parse(test::kSimDevicesToml + "[devices.filter_wheel]\nkind = \"sim\"\nslots = 12\nslot_b = 12\n");
  EXPECT_TRUE(sim.all_simulated());
  const dev::FilterWheelSetup s = dev::filter_wheel_config(*sim.filter_wheel);
  EXPECT_EQ(s.sim_slots, 12);
  EXPECT_EQ(s.channel_slot, (std::array<int, 3>{1, 2, 12}));
  EXPECT_FALSE(parse(test::kSimDevicesToml).filter_wheel);

  const auto error_of = [](const std::string& section) {
    return test::error_message<ConfigError>(
        [&] { dev::validate_device_sections(parse(test::kSimDevicesToml + "[devices.filter_wheel]\n" + section)); });
  };
  EXPECT_THAT(error_of("kind = \"sim\"\nslot_g = 1\n"),
              ::testing::AllOf(::testing::HasSubstr("devices.filter_wheel.slot_g"), ::testing::HasSubstr("already slot_r's")));
  EXPECT_THAT(error_of("kind = \"sim\"\nslot_b = 7\n"), ::testing::HasSubstr("devices.filter_wheel.slot_b"));
  EXPECT_THAT(error_of("kind = \"sim\"\nslots = 8\n"), ::testing::HasSubstr("6 or 12"));
  EXPECT_THAT(error_of("kind = \"serial\"\n"), ::testing::HasSubstr("devices.filter_wheel.port"));
  EXPECT_THAT(error_of("kind = \"serial\"\nport = \"/dev/ttyUSB0\"\nspeed = 1\n"),
              ::testing::HasSubstr("devices.filter_wheel.speed"));
  EXPECT_THROW(parse(test::kSimDevicesToml + "[devices.filter_wheel]\nkind = \"usb\"\n"), ConfigError);
}

}  // namespace
}  // namespace paintlab
