// GpiodLight's logic, linked against a fake of the libgpiod v1 functions (fake_gpiod_v1.cpp):
// read-back, active-low, the maximum on-time, release on every exit path incl. signals.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <thread>

#include "fake_gpiod_v1.h"
#include "paintlab/core/error.h"
#include "paintlab/devices/gpiod_light.h"

namespace paintlab {
namespace {

namespace fake = test::fake_gpiod;
using dev::GpiodLight;
using dev::GpiodLightConfig;

GpiodLightConfig config(double max_on_s = 60.0) {
  GpiodLightConfig c;
  c.chip = "gpiochip0";
  c.line = 17;
  c.consumer = "paintlab-test";
  c.max_on_s = max_on_s;
  c.handle_signals = false;
  return c;
}

TEST(GpiodLight, RequestsTheLineOffAndSwitchesWithReadBack) {
  fake::reset();
  {
    GpiodLight led(config());
    EXPECT_TRUE(fake::state().requested);
    EXPECT_EQ(fake::state().offset, 17u);
    EXPECT_STREQ(fake::state().consumer, "paintlab-test");
    EXPECT_EQ(fake::state().value, 0);
    ASSERT_TRUE(led.on());
    EXPECT_EQ(fake::state().wire, 1);
    auto on = led.is_on();
    ASSERT_TRUE(on);
    EXPECT_TRUE(*on);
    ASSERT_TRUE(led.off());
    EXPECT_EQ(fake::state().wire, 0);
    EXPECT_FALSE(led.has_level());
    EXPECT_FALSE(led.on(0.5));
    EXPECT_EQ(led.id(), "light gpiod gpiochip0 line 17");
  }
  EXPECT_FALSE(fake::state().requested);
  EXPECT_EQ(fake::state().releases, 1);
  EXPECT_EQ(fake::state().chips_open, 0);
}

TEST(GpiodLight, ActiveLowInvertsTheWire) {
  fake::reset();
  auto c = config();
  c.active_low = true;
  GpiodLight led(c);
  EXPECT_TRUE(fake::state().active_low);
  EXPECT_EQ(fake::state().wire, 1) << "off is high on an active-low line";
  ASSERT_TRUE(led.on());
  EXPECT_EQ(fake::state().wire, 0);
  auto on = led.is_on();
  ASSERT_TRUE(on);
  EXPECT_TRUE(*on);
}

TEST(GpiodLight, DestructionLeavesTheLedOffAndReleased) {
  fake::reset();
  {
    GpiodLight led(config());
    ASSERT_TRUE(led.on());
  }
  EXPECT_EQ(fake::state().value, 0);
  EXPECT_FALSE(fake::state().requested);
  EXPECT_EQ(fake::state().chips_open, 0);
}

TEST(GpiodLight, ExceptionUnwindingSwitchesOff) {
  fake::reset();
  try {
    GpiodLight led(config());
    ASSERT_TRUE(led.on());
    throw JobError("measurement stopped");
  } catch (const JobError&) {
  }
  EXPECT_EQ(fake::state().value, 0);
  EXPECT_FALSE(fake::state().requested);
}

TEST(GpiodLight, MaximumOnTimeSwitchesOff) {
  fake::reset();
  GpiodLight led(config(0.5));
  ASSERT_TRUE(led.on());
  std::this_thread::sleep_for(std::chrono::milliseconds(350));
  EXPECT_EQ(fake::state().wire, 1);
  ASSERT_TRUE(led.on());  // a second on() does not extend the switch-on ...
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(fake::state().wire, 0);  // ... off at 0.5 s, not at 0.85 s
  auto on = led.is_on();
  ASSERT_TRUE(on);
  EXPECT_FALSE(*on);
  EXPECT_EQ(led.max_on_trips(), 1);
  // Switching on again starts a new on-time; switching off stops the watchdog.
  ASSERT_TRUE(led.on());
  EXPECT_EQ(fake::state().wire, 1);
  ASSERT_TRUE(led.off());
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  EXPECT_EQ(led.max_on_trips(), 1);
}

TEST(GpiodLight, StuckLedIsDetected) {
  fake::reset();
  GpiodLight led(config());
  fake::state().stuck = true;
  auto r = led.on();
  ASSERT_FALSE(r);
  EXPECT_TRUE(r.error().retryable());
  EXPECT_THAT(r.error().what(), ::testing::HasSubstr("did not switch"));
}

TEST(GpiodLight, MissingChipOrBusyLineIsADeviceError) {
  fake::reset();
  auto c = config();
  c.chip = "gpiochip9";
  try {
    GpiodLight led(c);
    FAIL() << "opened a missing chip";
  } catch (const DeviceError& e) {
    EXPECT_FALSE(e.retryable());
    EXPECT_THAT(e.what(), ::testing::HasSubstr("gpiochip9"));
  }
  fake::reset();
  fake::state().fail_request = true;
  EXPECT_THROW(GpiodLight led(config()), DeviceError);
  EXPECT_EQ(fake::state().chips_open, 0);
}

// Runs `body` in a child process and returns its wait status.
template <class F>
int in_child(F body) {
  pid_t pid = fork();
  if (pid == 0) {
    body();
    _exit(0);
  }
  int st = 0;
  waitpid(pid, &st, 0);
  return st;
}

TEST(GpiodLight, SigtermSwitchesOffReleasesAndTerminates) {
  fake::reset(/*shared=*/true);
  int st = in_child([] {
    auto c = config();
    c.handle_signals = true;
    GpiodLight led(c);
    if (!led.on()) _exit(3);
    std::raise(SIGTERM);
    _exit(4);  // not reached: the default action terminates
  });
  ASSERT_TRUE(WIFSIGNALED(st)) << "status " << st;
  EXPECT_EQ(WTERMSIG(st), SIGTERM);
  EXPECT_EQ(fake::state().value, 0);
  EXPECT_FALSE(fake::state().requested);
  EXPECT_EQ(fake::state().releases, 1);
}

std::atomic<int>* g_flag = nullptr;
void previous_handler(int) {
  // The LED is already off when the application's own handler runs.
  g_flag->store(fake::state().value == 0 && !fake::state().requested ? 1 : 2);
}

TEST(GpiodLight, SigintRunsThePreviousHandlerAfterSwitchingOff) {
  fake::reset(/*shared=*/true);
  int st = in_child([] {
    static std::atomic<int> flag{0};
    g_flag = &flag;
    std::signal(SIGINT, previous_handler);
    auto c = config();
    c.handle_signals = true;
    GpiodLight led(c);
    if (!led.on()) _exit(3);
    std::raise(SIGINT);
    // The application decides to go on: later calls report the released line.
    auto r = led.on();
    _exit(flag.load() == 1 && !r ? 7 : 8);
  });
  ASSERT_TRUE(WIFEXITED(st)) << "status " << st;
  EXPECT_EQ(WEXITSTATUS(st), 7);
  EXPECT_EQ(fake::state().value, 0);
  EXPECT_EQ(fake::state().releases, 1);
}

}  // namespace
}  // namespace paintlab
