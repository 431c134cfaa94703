#include "paintlab/sim/virtual_clock.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "paintlab/core/error.h"

namespace paintlab::sim {

namespace {
void check_factor(double f) {
  if (!(f >= 0)) throw DataError("virtual clock: speed factor must be >= 0 (0 or inf: no real sleeping)");
}
}  // namespace

VirtualClock::VirtualClock(double speed_factor, double start_s) : now_(start_s), factor_(speed_factor) {
  check_factor(speed_factor);
}

double VirtualClock::now_s() const {
  std::lock_guard lock(mutex_);
  return now_;
}

void VirtualClock::sleep_s(double seconds) {
  if (!(seconds > 0)) return;
  double start, factor;
  {
    std::lock_guard lock(mutex_);
    start = now_;
    factor = factor_;
  }
  if (factor > 0 && std::isfinite(factor)) {
    double real = seconds / factor;
    {
      std::lock_guard lock(mutex_);
      real_slept_ += real;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(real));
  }
  advance_to_s(start + seconds);
}

void VirtualClock::advance_s(double seconds) {
  if (!(seconds > 0)) return;
  std::lock_guard lock(mutex_);
  now_ += seconds;
}

void VirtualClock::advance_to_s(double t_s) {
  std::lock_guard lock(mutex_);
  now_ = std::max(now_, t_s);
}

double VirtualClock::speed_factor() const {
  std::lock_guard lock(mutex_);
  return factor_;
}

void VirtualClock::set_speed_factor(double factor) {
  check_factor(factor);
  std::lock_guard lock(mutex_);
  factor_ = factor;
}

double VirtualClock::real_sleep_requested_s() const {
  std::lock_guard lock(mutex_);
  return real_slept_;
}

}  // namespace paintlab::sim
