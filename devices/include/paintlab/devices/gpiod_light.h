#pragma once
// GpiodLight: the LED on one GPIO output line (libgpiod 1.6, v1 API). The driver enforces a
// maximum on-time per switch-on (LED thermal safety, measured on the wall clock because the
// heat is real), reads the line back after every switch, and leaves the LED off with the
// line released on every exit path: destruction, exceptions, and SIGINT/SIGTERM (a handler
// switches every open GpiodLight off, then runs the previously installed handler or
// re-raises the signal with the default action).
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "paintlab/core/config.h"
#include "paintlab/devices/light.h"

namespace paintlab::dev {

namespace detail {
struct GpioSlot;  // a line registered for the signal handler
}

struct GpiodLightConfig {
  std::string chip = "gpiochip0";  // name, number, label or /dev path
  unsigned line = 0;               // line offset on the chip
  bool active_low = false;
  std::string consumer = "paintlab-led";
  double max_on_s = 60.0;          // longest time one on() may keep the LED lit
  bool handle_signals = true;      // install the SIGINT/SIGTERM switch-off handler

  void check() const;  // throws DataError naming the first violated rule
};

// Reads a [devices.light] table of kind "gpiod"; unknown keys are ConfigErrors.
GpiodLightConfig gpiod_light_config(const ConfigTable& table);

class GpiodLight final : public Light {
 public:
  // Requests the line as an output, initially off. Throws DeviceError (not retryable) when
  // the chip or line cannot be opened.
  explicit GpiodLight(GpiodLightConfig config);
  ~GpiodLight() override;  // LED off, line released
  GpiodLight(const GpiodLight&) = delete;
  GpiodLight& operator=(const GpiodLight&) = delete;

  std::string id() const override;
  Result<void> on(double level = 1.0) override;
  Result<void> off() override;
  Result<bool> is_on() override;
  bool has_level() const override { return false; }

  // How often the max on-time switched the LED off.
  int max_on_trips() const;

 private:
  Result<void> set_locked(int value, const char* what);
  void watchdog();

  GpiodLightConfig config_;
  detail::GpioSlot* slot_ = nullptr;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool lit_ = false;
  std::uint64_t on_generation_ = 0;
  bool stopping_ = false;
  int trips_ = 0;
  std::thread watchdog_;
};

struct GpioChipInfo {
  std::string name;
  std::string label;
  unsigned lines = 0;
};
// The gpiochips of this machine (for `paintlab devices`).
std::vector<GpioChipInfo> list_gpiochips();

}  // namespace paintlab::dev
