#pragma once
// A virtual clock for driver tests: sleep_s() advances time at once (thread-safe), so
// motion and settling take their physical durations in virtual time only.
#include <mutex>

#include "paintlab/core/clock.h"

namespace paintlab::test {

class StepClock final : public Clock {
 public:
  double now_s() const override {
    std::lock_guard lock(mutex_);
    return now_;
  }
  void sleep_s(double seconds) override {
    std::lock_guard lock(mutex_);
    if (seconds > 0) now_ += seconds;
  }

 private:
  mutable std::mutex mutex_;
  double now_ = 1000.0;
};

}  // namespace paintlab::test
