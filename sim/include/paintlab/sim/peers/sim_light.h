#pragma once
// SimLight: the simulated LED behind the Light interface. It switches the simulated world's
// LED (through `on_change`), reads the state back like the real driver does, enforces the
// maximum on-time on the sim clock, and has a fault switch for an LED that does not switch.
#include <functional>
#include <mutex>
#include <string>

#include "paintlab/core/clock.h"
#include "paintlab/devices/light.h"

namespace paintlab::sim {

struct SimLightOptions {
  double max_on_s = 60.0;
};

class SimLight final : public dev::Light {
 public:
  using OnChange = std::function<void(bool on)>;
  SimLight(SimLightOptions options, Clock& clock, OnChange on_change = {});

  std::string id() const override { return "light sim"; }
  Result<void> on(double level = 1.0) override;
  Result<void> off() override;
  Result<bool> is_on() override;
  bool has_level() const override { return false; }

  // Fault: the LED stays as it is whatever is commanded.
  void set_stuck(bool stuck);
  // The truth: whether the LED emits now (after the max on-time check at the clock's now).
  bool emitting();
  int max_on_trips() const;

 private:
  Result<void> set(bool on, const char* what);
  void enforce_locked();

  SimLightOptions options_;
  Clock& clock_;
  OnChange on_change_;
  mutable std::mutex mutex_;
  bool lit_ = false;
  bool stuck_ = false;
  double on_since_s_ = 0.0;
  int trips_ = 0;
};

// A Light that forwards to a SimLight owned elsewhere (the SimRig keeps its SimLight, whose
// state the simulated camera's frames read; the rig's devices hold this handle to it).
class SimLightHandle final : public dev::Light {
 public:
  explicit SimLightHandle(dev::Light& light) : light_(light) {}
  std::string id() const override { return light_.id(); }
  Result<void> on(double level = 1.0) override { return light_.on(level); }
  Result<void> off() override { return light_.off(); }
  Result<bool> is_on() override { return light_.is_on(); }
  bool has_level() const override { return light_.has_level(); }

 private:
  dev::Light& light_;
};

}  // namespace paintlab::sim
