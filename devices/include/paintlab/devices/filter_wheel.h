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
};

}  // namespace paintlab::dev
