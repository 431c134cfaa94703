#include "paintlab/sim/peers/sim_light.h"

#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/core/log.h"

namespace paintlab::sim {

SimLight::SimLight(SimLightOptions options, Clock& clock, OnChange on_change)
    : options_(options), clock_(clock), on_change_(std::move(on_change)) {
  if (!(options_.max_on_s > 0)) throw DataError("sim light: max_on_s must be > 0");
}

void SimLight::enforce_locked() {
  if (lit_ && !stuck_ && clock_.now_s() - on_since_s_ > options_.max_on_s) {
    lit_ = false;
    ++trips_;
    if (on_change_) on_change_(false);
    spdlog::warn("light sim: on for longer than max_on_s = {:g} s: switched off", options_.max_on_s);
  }
}

Result<void> SimLight::set(bool on, const char* what) {
  std::lock_guard lock(mutex_);
  enforce_locked();
  if (!stuck_) {
    if (on && !lit_) on_since_s_ = clock_.now_s();
    lit_ = on;
    if (on_change_) on_change_(on);
  }
  // Read back, as the GPIO driver does.
  if (lit_ != on)
    return device_failure(id(), fmt::format("{}: the LED did not switch (commanded {}, reads {})", what, on ? 1 : 0,
                                            lit_ ? 1 : 0),
                          true);
  return {};
}

Result<void> SimLight::on(double level) {
  if (!(level > 0 && level <= 1))
    return device_failure(id(), fmt::format("on({:g}): level must be in (0, 1]", level), false);
  if (level != 1.0) return device_failure(id(), fmt::format("on({:g}): this LED has no dimming (level 1 only)", level), false);
  return set(true, "on");
}

Result<void> SimLight::off() { return set(false, "off"); }

Result<bool> SimLight::is_on() {
  std::lock_guard lock(mutex_);
  enforce_locked();
  return lit_;
}

void SimLight::set_stuck(bool stuck) {
  std::lock_guard lock(mutex_);
  stuck_ = stuck;
}

bool SimLight::emitting() {
  std::lock_guard lock(mutex_);
  enforce_locked();
  return lit_;
}

int SimLight::max_on_trips() const {
  std::lock_guard lock(mutex_);
  return trips_;
}

}  // namespace paintlab::sim
