#pragma once
// The simulated rig's clock. Event-driven: virtual time moves only when somebody waits
// (sleep_s) or a test advances it, so a 328 ms exposure takes 328 ms of virtual time
// however long the rendering takes, and sessions record physical durations. With a speed
// factor k > 0 each wait also sleeps d / k of real time (pacing for people watching and
// for real protocol timeouts); k = 0 or infinity never sleeps for real.
//
// Thread-safe. Concurrent waits overlap as they would in real time: a wait of d that
// starts at virtual time t0 ends with now_s() >= t0 + d, and time never goes backwards.
#include <mutex>

#include "paintlab/core/clock.h"

namespace paintlab::sim {

class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(double speed_factor = 0.0, double start_s = 0.0);

  double now_s() const override;
  void sleep_s(double seconds) override;

  // Moves virtual time forward by `seconds` without sleeping (tests, simulated peers).
  void advance_s(double seconds);
  // Moves virtual time forward to `t_s` if it is later than now.
  void advance_to_s(double t_s);

  double speed_factor() const;
  void set_speed_factor(double factor);  // >= 0 (0 or infinity: no real sleeping)
  // Total real seconds this clock asked the OS to sleep (for checking the pacing).
  double real_sleep_requested_s() const;

 private:
  mutable std::mutex mutex_;
  double now_;
  double factor_;
  double real_slept_ = 0.0;
};

}  // namespace paintlab::sim
