// SerialFilterWheel (devices/serial_filter_wheel.h) against the simulated wheel on a real
// pseudo-terminal pair: the FW102C exchange (echo, answer, prompt), moves read back, retries
// after silence and garbled echoes, a refused command, and a wheel that never arrives.
#include "paintlab/devices/serial_filter_wheel.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/peers/sim_filter_wheel.h"
#include "paintlab/sim/virtual_clock.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {

// The wheel and the driver on one virtual clock: moves take their simulated time, the test
// does not wait for them.
struct WheelRig {
  sim::VirtualClock clock;
  sim::SimFilterWheel wheel;
  dev::SerialFilterWheel driver;
  explicit WheelRig(sim::SimFilterWheelOptions o = {}, double response_timeout_s = 0.3)
      : wheel(o, clock), driver(config(wheel.port(), response_timeout_s), clock) {}
  static dev::SerialFilterWheelConfig config(const std::string& port, double timeout_s) {
    dev::SerialFilterWheelConfig c;
    c.port = port;
    c.response_timeout_s = timeout_s;
    c.move_timeout_s = 3.0;
    c.settle_s = 0.1;
    return c;
  }
};

}  // namespace

TEST(SerialFilterWheel, IdentifiesCountsAndMovesReadingTheSlotBack) {
  WheelRig rig;
  const auto idn = rig.driver.identify();
  ASSERT_TRUE(idn) << idn.error().what();
  EXPECT_THAT(*idn, HasSubstr("FW102C"));
  ASSERT_EQ(rig.driver.slot_count().value(), 6);
  ASSERT_EQ(rig.driver.position().value(), 1);
  const double t0 = rig.clock.now_s();
  const auto moved = rig.driver.move_to(4);
  ASSERT_TRUE(moved) << moved.error().what();
  EXPECT_EQ(rig.wheel.position(), 4);
  EXPECT_EQ(rig.driver.position().value(), 4);
  // Three slots at 0.2 s each, polled every 50 ms, then 0.1 s to settle.
  EXPECT_NEAR(rig.clock.now_s() - t0, 0.7, 0.06);
  // The shorter way round: 4 -> 1 is three slots either way, 6 -> 1 one.
  ASSERT_TRUE(rig.driver.move_to(6));
  const double t1 = rig.clock.now_s();
  ASSERT_TRUE(rig.driver.move_to(1));
  EXPECT_NEAR(rig.clock.now_s() - t1, 0.3, 0.06);
  EXPECT_EQ(rig.driver.retry_count(), 0);
}

TEST(SerialFilterWheel, SilenceAndGarbledEchoesAreRetried) {
  WheelRig rig;
  rig.wheel.set_faults({.silent = 1, .garbled = 1});
  const auto at = rig.driver.position();
  ASSERT_TRUE(at) << at.error().what();
  EXPECT_EQ(*at, 1);
  EXPECT_EQ(rig.driver.retry_count(), 2);
  rig.wheel.set_faults({.silent = 10});
  const auto lost = rig.driver.position();
  ASSERT_FALSE(lost);
  EXPECT_TRUE(lost.error().retryable());
  EXPECT_THAT(lost.error().what(), AllOf(HasSubstr("'pos?'"), HasSubstr("no prompt within 0.3 s")));
}

TEST(SerialFilterWheel, ASlotThatDoesNotExistOrAStuckWheelIsADeviceFault) {
  WheelRig rig;
  const auto none = rig.driver.move_to(7);
  ASSERT_FALSE(none);
  EXPECT_FALSE(none.error().retryable());
  EXPECT_THAT(none.error().what(), HasSubstr("slot 7 does not exist (the wheel has 1..6)"));
  rig.wheel.set_faults({.stuck = true});
  const int moves = rig.wheel.moves();
  const auto stuck = rig.driver.move_to(3);
  ASSERT_FALSE(stuck);
  EXPECT_TRUE(stuck.error().retryable());
  EXPECT_THAT(stuck.error().what(), AllOf(HasSubstr("did not reach slot 3 (3 attempts)"), HasSubstr("at slot 1")));
  EXPECT_EQ(rig.wheel.moves() - moves, 3) << "pos=3 sent once and resent twice";
  EXPECT_EQ(rig.wheel.position(), 1);
}

// What the wheel refuses is said and not retried.
TEST(SerialFilterWheel, ACommandErrorNamesTheCommandAndIsNotRetried) {
  WheelRig rig;
  rig.wheel.set_faults({.refused = 1});
  const auto at = rig.driver.position();
  ASSERT_FALSE(at);
  EXPECT_FALSE(at.error().retryable());
  EXPECT_THAT(at.error().what(), HasSubstr("'pos?' refused: Command error CMD_NOT_DEFINED"));
  EXPECT_EQ(rig.driver.retry_count(), 0);
  EXPECT_EQ(rig.driver.position().value(), 1);
}

// The physical minimum of a move (the sweep's minimum counts it): slots the shorter way round
// at move_ms_per_slot, plus the settle wait; the moves take within 5 % of it (the driver polls
// pos? every 10 ms, so it sees the arrival at most 10 ms late).
TEST(SerialFilterWheel, MovesTakeWithinFivePercentOfTheirPhysicalMinimum) {
  sim::VirtualClock clock;
  sim::SimFilterWheel wheel({}, clock);
  dev::SerialFilterWheelConfig c = WheelRig::config(wheel.port(), 0.3);
  c.settle_s = 0.05;  // the demo rig's
  c.move_s_per_slot = 0.2;
  dev::SerialFilterWheel driver(c, clock);
  ASSERT_TRUE(driver.move_to(1));
  EXPECT_NEAR(driver.min_move_s(1, 4), 3 * 0.2 + 0.05, 1e-12);
  EXPECT_NEAR(driver.min_move_s(6, 1), 0.2 + 0.05, 1e-12);  // the shorter way round
  EXPECT_EQ(driver.min_move_s(3, 3), 0.0);
  double took = 0.0, minimum = 0.0;
  int at = 1;
  for (int slot : {2, 3, 2, 1, 4, 6, 1, 3}) {
    const double t0 = clock.now_s();
    ASSERT_TRUE(driver.move_to(slot));
    took += clock.now_s() - t0;
    minimum += driver.min_move_s(at, slot);
    at = slot;
  }
  std::printf("8 moves: %.3f s, physical minimum %.3f s, ratio %.3f\n", took, minimum, took / minimum);
  EXPECT_GE(took, minimum * 0.999);
  EXPECT_LE(took, minimum * 1.05);
  c.move_s_per_slot = 0.0;  // unknown: no minimum
  EXPECT_EQ(dev::SerialFilterWheel(c, clock).min_move_s(1, 4), 0.0);
}

TEST(SerialFilterWheel, ATwelveSlotWheelIsCountedAndReached) {
  WheelRig rig(sim::SimFilterWheelOptions{.slots = 12});
  EXPECT_EQ(rig.driver.slot_count().value(), 12);
  ASSERT_TRUE(rig.driver.move_to(12));
  EXPECT_EQ(rig.wheel.position(), 12);
}

TEST(SerialFilterWheel, RigTomlKeysAndBadPortsAreReportedByName) {
  const ConfigTable t = ConfigTable::parse_string(
      "port = \"/dev/ttyUSB0\"\nsettle_ms = 300\nbaud = 9600\nmove_ms_per_slot = 250\n", "rig.toml");
  const dev::SerialFilterWheelConfig c = dev::serial_filter_wheel_config(t);
  EXPECT_DOUBLE_EQ(c.move_s_per_slot, 0.25);
  EXPECT_EQ(c.port, "/dev/ttyUSB0");
  EXPECT_DOUBLE_EQ(c.settle_s, 0.3);
  EXPECT_EQ(c.baud, 9600);
  EXPECT_THAT(test::error_message<ConfigError>([] {
                dev::serial_filter_wheel_config(ConfigTable::parse_string("port = \"/dev/x\"\nbaud = 14400\n", "rig.toml"));
              }),
              AllOf(HasSubstr("baud"), HasSubstr("115200")));
  dev::SerialFilterWheelConfig missing;
  missing.port = "/nonexistent/ttyUSB9";
  EXPECT_THAT(test::error_message<DeviceError>([&] { dev::SerialFilterWheel w(missing); }),
              AllOf(HasSubstr("filter wheel serial /nonexistent/ttyUSB9"), HasSubstr("cannot open")));
  missing.port = "/dev/null";
  EXPECT_THAT(test::error_message<DeviceError>([&] { dev::SerialFilterWheel w(missing); }),
              HasSubstr("not a serial line"));
}
