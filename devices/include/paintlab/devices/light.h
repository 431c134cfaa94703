#pragma once
// The LED on the arm. on()/off() switch it; is_on() reads the state back from the
// hardware (not from a cached flag) so a stuck LED is detected.
#include <string>

#include "paintlab/core/result.h"

namespace paintlab::dev {

class Light {
 public:
  virtual ~Light() = default;
  virtual std::string id() const = 0;
  // Switches on at `level` in (0, 1] (hardware without dimming accepts only 1).
  virtual Result<void> on(double level = 1.0) = 0;
  virtual Result<void> off() = 0;
  virtual Result<bool> is_on() = 0;
  virtual bool has_level() const = 0;
};

}  // namespace paintlab::dev
