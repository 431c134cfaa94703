// SimLight: the simulated LED behind the Light interface, its read-back, the maximum
// on-time on the sim clock and the stuck-LED fault.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/sim/peers/sim_light.h"
#include "fake_rig.h"

namespace paintlab {
namespace {


TEST(SimLight, SwitchesTheWorldsLedAndReadsBack) {
  test::FakeClock clock(0.0);
  bool world_led = false;
  sim::SimLight led({}, clock, [&](bool on) { world_led = on; });
  ASSERT_TRUE(led.on());
  EXPECT_TRUE(world_led);
  EXPECT_TRUE(*led.is_on());
  ASSERT_TRUE(led.off());
  EXPECT_FALSE(world_led);
  EXPECT_FALSE(led.on(0.3));
}

TEST(SimLight, MaximumOnTimeOnTheSimClock) {
  test::FakeClock clock(0.0);
  bool world_led = false;
  sim::SimLight led({.max_on_s = 2.0}, clock, [&](bool on) { world_led = on; });
  ASSERT_TRUE(led.on());
  clock.sleep_s(1.5);
  EXPECT_TRUE(led.emitting());
  clock.sleep_s(1.0);
  EXPECT_FALSE(led.emitting());
  EXPECT_FALSE(world_led);
  EXPECT_EQ(led.max_on_trips(), 1);
}

TEST(SimLight, StuckLedIsReportedAsNotSwitching) {
  test::FakeClock clock(0.0);
  sim::SimLight led({}, clock);
  led.set_stuck(true);
  auto r = led.on();
  ASSERT_FALSE(r);
  EXPECT_TRUE(r.error().retryable());
  EXPECT_THAT(r.error().what(), ::testing::HasSubstr("did not switch"));
  EXPECT_FALSE(*led.is_on());
  led.set_stuck(false);
  EXPECT_TRUE(led.on());
}

}  // namespace
}  // namespace paintlab
