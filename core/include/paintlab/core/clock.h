#pragma once
// Time as the rig sees it. Drivers and the acquisition runner wait through a Clock, so
// the simulated rig can run on a virtual clock (sim::VirtualClock) on which motion,
// exposure and readout take their physical durations while the test runs faster.
#include <chrono>
#include <thread>

namespace paintlab {

class Clock {
 public:
  virtual ~Clock() = default;
  // Seconds since an arbitrary origin (monotonic).
  virtual double now_s() const = 0;
  // Waits `seconds` on this clock.
  virtual void sleep_s(double seconds) = 0;
};

// The wall clock (steady_clock).
class SystemClock final : public Clock {
 public:
  double now_s() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  void sleep_s(double seconds) override {
    if (seconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  }
};

// A process-wide SystemClock for drivers that are not given a clock.
inline Clock& system_clock() {
  static SystemClock clock;
  return clock;
}

}  // namespace paintlab
