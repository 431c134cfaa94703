#pragma once
// The turntable that carries the LED arm. Angles in degrees (table angle as the
// controller counts it). Motion commands start a move and return; wait_settled() waits
// for in-position. Expected failures are Result values (see core/result.h).
#include <string>

#include "paintlab/core/result.h"

namespace paintlab::dev {

struct TurntableStatus {
  bool ready = false;        // accepts commands
  bool moving = false;
  bool in_position = false;
  bool homed = false;
  int alarm_code = 0;        // 0 = no alarm
  double angle_deg = 0.0;    // encoder (feedback) position
};

class Turntable {
 public:
  virtual ~Turntable() = default;
  // A name for messages: kind, address, unit ("turntable modbus-tcp 127.0.0.1:1502 unit 1").
  virtual std::string id() const = 0;
  // Starts homing (return to the mechanical zero). Wait with wait_settled().
  virtual Result<void> home() = 0;
  // Starts an absolute move to angle_deg (within the configured limits).
  virtual Result<void> move_to(double angle_deg) = 0;
  // Encoder position read back from the controller.
  virtual Result<double> angle_deg() = 0;
  virtual Result<TurntableStatus> status() = 0;
  // Waits until the table is in position and not moving; returns the settled angle.
  // Not settling within timeout_s is an error (retryable: the move may be re-issued).
  virtual Result<double> wait_settled(double timeout_s) = 0;
  // Stops any motion at once (decelerating stop).
  virtual Result<void> stop() = 0;
  // Clears a controller alarm.
  virtual Result<void> reset_alarm() = 0;
  // The time the configured motion profile (speed, acceleration) needs from one angle to
  // another, without polling or settling: the physical minimum the session's timing
  // summary compares against.
  virtual double move_time_s(double from_deg, double to_deg) const = 0;
};

}  // namespace paintlab::dev
