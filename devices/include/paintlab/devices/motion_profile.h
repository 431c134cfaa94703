#pragma once
// A trapezoidal (or, for short moves, triangular) velocity profile: accelerate at `accel`,
// cruise at `speed`, decelerate at `decel`. Units are whatever the caller uses (deg, counts);
// the driver uses it for move_time_s(), the simulated controller for the table's motion.
#include <algorithm>
#include <cmath>

namespace paintlab::dev {

struct TrapezoidProfile {
  double distance = 0.0;  // >= 0
  double speed = 1.0;     // > 0
  double accel = 1.0;     // > 0
  double decel = 1.0;     // > 0

  // Peak speed actually reached (below `speed` for short moves).
  double peak_speed() const {
    double full = speed * speed / (2 * accel) + speed * speed / (2 * decel);
    if (distance >= full) return speed;
    return std::sqrt(2 * distance / (1 / accel + 1 / decel));
  }
  double duration() const {
    if (distance <= 0) return 0.0;
    double vp = peak_speed();
    double d_acc = vp * vp / (2 * accel), d_dec = vp * vp / (2 * decel);
    return vp / accel + vp / decel + (distance - d_acc - d_dec) / vp;
  }
  // Distance covered after t seconds (clamped to [0, distance]).
  double position_at(double t) const {
    if (distance <= 0 || t <= 0) return 0.0;
    double vp = peak_speed();
    double t_acc = vp / accel, t_dec = vp / decel;
    double d_acc = vp * t_acc / 2, d_dec = vp * t_dec / 2;
    double t_cruise = (distance - d_acc - d_dec) / vp;
    if (t < t_acc) return accel * t * t / 2;
    if (t < t_acc + t_cruise) return d_acc + vp * (t - t_acc);
    double td = t - t_acc - t_cruise;
    if (td >= t_dec) return distance;
    return std::min(distance, d_acc + vp * t_cruise + vp * td - decel * td * td / 2);
  }
  // Speed after t seconds.
  double speed_at(double t) const {
    if (distance <= 0 || t <= 0) return 0.0;
    double vp = peak_speed();
    double t_acc = vp / accel, t_dec = vp / decel;
    double t_cruise = (distance - vp * t_acc / 2 - vp * t_dec / 2) / vp;
    if (t < t_acc) return accel * t;
    if (t < t_acc + t_cruise) return vp;
    double td = t - t_acc - t_cruise;
    return std::max(0.0, vp - decel * td);
  }
};

// Angle in [0, 360).
inline double wrap_deg(double a) {
  double r = std::fmod(a, 360.0);
  if (r < 0) r += 360.0;
  if (r >= 360.0) r = 0.0;
  return r;
}

}  // namespace paintlab::dev
