#pragma once
// A filter wheel in front of a monochrome camera: one colour filter per slot (slots count
// from 1, as the wheels label them). move_to() returns once the wheel reports the slot
// reached (read back, not assumed); a wheel that does not get there is a DeviceError.
#include <string>

#include "paintlab/core/result.h"

namespace paintlab::dev {

class FilterWheel {
 public:
  virtual ~FilterWheel() = default;
  virtual std::string id() const = 0;       // kind and port ("filter wheel serial /dev/ttyUSB0")
  virtual Result<std::string> identify() = 0;  // the device's own model and firmware line
  virtual Result<int> slot_count() = 0;     // 6 or 12 on the usual wheels
  virtual Result<int> position() = 0;       // the slot in front of the lens, read back
  virtual Result<void> move_to(int slot) = 0;
  // The physical minimum of a move from one slot to another (the wheel's time per slot step,
  // the shorter way round, plus its settle wait): what the sweep's physical minimum counts for
  // a move. 0 when the wheel's speed is not known (the measured time then counts).
  virtual double min_move_s(int from_slot, int to_slot) const {
    (void)from_slot;
    (void)to_slot;
    return 0.0;
  }
};

}  // namespace paintlab::dev
