#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "paintlab/core/error.h"
#include "paintlab/sim/virtual_clock.h"

using namespace paintlab;

TEST(VirtualClock, SleepAdvancesVirtualTimeWithoutRealSleep) {
  sim::VirtualClock clock(0.0, 10.0);
  EXPECT_DOUBLE_EQ(clock.now_s(), 10.0);
  auto t0 = std::chrono::steady_clock::now();
  clock.sleep_s(3600.0);  // an hour of exposures
  double real = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_DOUBLE_EQ(clock.now_s(), 3610.0);
  EXPECT_LT(real, 0.5);
  EXPECT_DOUBLE_EQ(clock.real_sleep_requested_s(), 0.0);
  clock.sleep_s(-1.0);  // negative and zero waits do nothing
  clock.sleep_s(0.0);
  EXPECT_DOUBLE_EQ(clock.now_s(), 3610.0);
}

TEST(VirtualClock, InfiniteFactorNeverSleeps) {
  sim::VirtualClock clock(std::numeric_limits<double>::infinity());
  clock.sleep_s(100.0);
  EXPECT_DOUBLE_EQ(clock.now_s(), 100.0);
  EXPECT_DOUBLE_EQ(clock.real_sleep_requested_s(), 0.0);
}

TEST(VirtualClock, SpeedFactorPacesRealTime) {
  sim::VirtualClock clock(100.0);
  auto t0 = std::chrono::steady_clock::now();
  clock.sleep_s(5.0);  // 50 ms real
  double real = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_DOUBLE_EQ(clock.now_s(), 5.0);
  EXPECT_GE(real, 0.049);
  EXPECT_LT(real, 1.0);
  EXPECT_DOUBLE_EQ(clock.real_sleep_requested_s(), 0.05);
  EXPECT_THROW(clock.set_speed_factor(-1), DataError);
  EXPECT_THROW(sim::VirtualClock(-2.0), DataError);
}

TEST(VirtualClock, ConcurrentWaitsOverlapAndTimeIsMonotonic) {
  // Factor 10: long enough real waits that thread start-up jitter does not reorder them.
  sim::VirtualClock clock(10.0);
  // Four threads wait 2 s each at the same time: 2 s of virtual time pass, not 8.
  std::vector<std::thread> threads;
  std::vector<double> woke(4);
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([&, k] {
      clock.sleep_s(2.0);
      woke[static_cast<std::size_t>(k)] = clock.now_s();
    });
  for (auto& t : threads) t.join();
  EXPECT_DOUBLE_EQ(clock.now_s(), 2.0);
  for (double w : woke) EXPECT_GE(w, 2.0);
  // A short wait started together with a long one ends first.
  double short_end = 0, long_end = 0;
  std::thread a([&] {
    clock.sleep_s(4.0);
    long_end = clock.now_s();
  });
  std::thread b([&] {
    clock.sleep_s(0.5);
    short_end = clock.now_s();
  });
  a.join();
  b.join();
  EXPECT_GE(short_end, 2.5);
  EXPECT_LT(short_end, 6.0);
  EXPECT_DOUBLE_EQ(long_end, 6.0);
  clock.advance_to_s(1.0);  // never backwards
  EXPECT_DOUBLE_EQ(clock.now_s(), 6.0);
  clock.advance_s(0.25);
  EXPECT_DOUBLE_EQ(clock.now_s(), 6.25);
}
