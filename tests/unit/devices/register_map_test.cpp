// Register maps as data: built-in maps, rig.toml overrides, encoding, motion units and the
// trapezoidal profile.
#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/devices/motion_profile.h"
#include "paintlab/devices/register_map.h"
#include "test_util.h"

namespace paintlab {
namespace {

using namespace dev;

TEST(RegisterMap, BuiltInMapsAreValid) {
  for (const auto& name : builtin_register_maps()) {
    RegisterMap m = builtin_register_map(name);
    EXPECT_EQ(m.name, name);
    EXPECT_NO_THROW(m.check()) << name;
  }
  EXPECT_THROW(builtin_register_map("acme"), DataError);
}

TEST(RegisterMap, OrientalAzAddresses) {
  RegisterMap m = builtin_register_map("oriental-az");
  EXPECT_EQ(m.operation_type.address, 0x005A);
  EXPECT_EQ(m.target_position.address, 0x005C);
  EXPECT_EQ(m.speed.address, 0x005E);
  EXPECT_EQ(m.start.reg.address, 0x0066);
  EXPECT_EQ(m.home.reg.address, 0x007D);
  EXPECT_EQ(m.home.value, 0x10);
  EXPECT_EQ(m.stop.value, 0x20);
  EXPECT_EQ(m.alarm_reset.value, 0x80);
  EXPECT_EQ(m.status.reg.address, 0x007F);
  EXPECT_EQ(m.alarm_code.address, 0x0080);
  EXPECT_EQ(m.encoder_position.address, 0x0120);
  EXPECT_EQ(m.op_wrap_absolute, 8);
}

TEST(RegisterMap, EncodesBothWordOrdersAndSigns) {
  RegisterMap m = builtin_register_map("oriental-az");
  RegisterField f{0x10, 2, true};
  auto r = encode_field(m, f, -2);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0], 0xFFFF);
  EXPECT_EQ(r[1], 0xFFFE);
  EXPECT_EQ(decode_field(m, f, r.data()), -2);
  r = encode_field(m, f, 0x12345678);
  EXPECT_EQ(r[0], 0x1234);
  EXPECT_EQ(r[1], 0x5678);
  m.high_word_first = false;
  r = encode_field(m, f, 0x12345678);
  EXPECT_EQ(r[0], 0x5678);
  EXPECT_EQ(decode_field(m, f, r.data()), 0x12345678);
  RegisterField u{0x10, 1, false};
  std::uint16_t one = 0xFFFF;
  EXPECT_EQ(decode_field(m, u, &one), 65535);
  u.is_signed = true;
  EXPECT_EQ(decode_field(m, u, &one), -1);
}

TEST(RegisterMap, MotionUnitsRoundTrip) {
  MotionScale s{100.0, 10000.0};
  RegisterMap az = builtin_register_map("oriental-az");
  EXPECT_EQ(speed_to_register(az, s, 30.0), 3000);  // Hz = counts/s
  EXPECT_DOUBLE_EQ(speed_from_register(az, s, 3000), 30.0);
  EXPECT_EQ(accel_to_register(az, s, 60.0), 6000);
  RegisterMap ls = builtin_register_map("leadshine-pr");
  // 30 deg/s = 3000 counts/s = 18 rpm of a 10000-count motor.
  EXPECT_EQ(speed_to_register(ls, s, 30.0), 18);
  EXPECT_NEAR(speed_from_register(ls, s, 18), 30.0, 1e-9);
  // 60 deg/s^2 = 36 rpm/s: 1000 rpm take 27778 ms.
  EXPECT_EQ(accel_to_register(ls, s, 60.0), 27778);
  EXPECT_NEAR(accel_from_register(ls, s, 27778), 60.0, 0.01);
}

TEST(RegisterMap, FromRigTomlBuiltInOverridesAndCustom) {
  auto root = ConfigTable::parse_string(R"(
[a]
register_map = "leadshine-pr"
[b.register_map]
base = "oriental-az"
encoder_position = { address = 0x0204 }
current = "none"
status = { address = 0x007F, ready_bit = 5, alarm_bit = 7, moving_mask = 0x2000, in_position_bit = 14 }
[c.register_map]
word_order = "low-first"
target_position = { address = 10 }
speed = { address = 12, words = 1 }
start = { address = 20, value = 1 }
status = { address = 21, moving_mask = 1 }
encoder_position = { address = 22 }
[d.register_map]
base = "oriental-az"
speeed = { address = 1 }
[e.register_map]
target_position = { address = 10 }
speed = { address = 11 }
start = { address = 20, value = 1 }
status = { address = 21, moving_mask = 1 }
encoder_position = { address = 22 }
)",
                                        "rig.toml");
  EXPECT_EQ(register_map_from_config(root.table("a")).name, "leadshine-pr");
  RegisterMap b = register_map_from_config(root.table("b"));
  EXPECT_EQ(b.encoder_position.address, 0x0204);
  EXPECT_FALSE(b.current.present());
  EXPECT_EQ(b.status.moving_mask, 0x2000);
  EXPECT_EQ(b.target_position.address, 0x005C);  // kept from the base
  RegisterMap c = register_map_from_config(root.table("c"));
  EXPECT_FALSE(c.high_word_first);
  EXPECT_EQ(c.speed.words, 1);
  try {
    register_map_from_config(root.table("d"));
    FAIL() << "misspelt key accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "d.register_map.speeed");
    EXPECT_EQ(e.line(), 18);
  }
  // target_position (2 words at 10..11) overlaps speed at 11.
  EXPECT_THAT(test::error_message<ConfigError>([&] { register_map_from_config(root.table("e")); }),
              ::testing::HasSubstr("overlaps"));
}

TEST(TrapezoidProfile, TrapezoidAndTriangle) {
  TrapezoidProfile p{90.0, 30.0, 60.0, 60.0};
  EXPECT_NEAR(p.duration(), 3.5, 1e-12);
  EXPECT_NEAR(p.position_at(0.5), 7.5, 1e-12);
  EXPECT_NEAR(p.position_at(3.5), 90.0, 1e-12);
  EXPECT_NEAR(p.speed_at(1.0), 30.0, 1e-12);
  // Short move: peak below the cruise speed.
  TrapezoidProfile t{5.0, 30.0, 60.0, 60.0};
  EXPECT_LT(t.peak_speed(), 30.0);
  EXPECT_NEAR(t.duration(), 2 * std::sqrt(5.0 / 60.0), 1e-12);
  EXPECT_NEAR(t.position_at(t.duration()), 5.0, 1e-9);
  // Monotonic.
  double last = 0;
  for (double s = 0; s <= 3.6; s += 0.01) {
    double x = p.position_at(s);
    EXPECT_GE(x, last - 1e-12);
    last = x;
  }
  EXPECT_DOUBLE_EQ(wrap_deg(-90.0), 270.0);
  EXPECT_DOUBLE_EQ(wrap_deg(720.0), 0.0);
}

}  // namespace
}  // namespace paintlab
