#include "paintlab/devices/gpiod_light.h"

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fmt/format.h>

#include "gpiod/gpiod_v1_adapter.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"

namespace paintlab::dev {

// Lines registered for the signal handler. state: 0 free, 1 claimed (being set up),
// 2 active (owned by a GpiodLight), 3 switched off and released by the signal handler.
namespace detail {
struct GpioSlot {
  std::atomic<int> state{0};
  gpiod_v1::OutputLine line;
};
}  // namespace detail

namespace {

constexpr int kSlots = 16;
detail::GpioSlot* slots();

struct sigaction g_prev_int;
struct sigaction g_prev_term;
std::once_flag g_handlers_once;

void switch_all_off_from_signal() {
  detail::GpioSlot* s = slots();
  for (int i = 0; i < kSlots; ++i) {
    int expected = 2;
    if (s[i].state.compare_exchange_strong(expected, 3)) {
      gpiod_v1::set_value(s[i].line, 0);
      gpiod_v1::release_line(s[i].line);
    }
  }
}

void on_signal(int sig, siginfo_t* info, void* ctx) {
  int saved_errno = errno;
  switch_all_off_from_signal();
  const struct sigaction& prev = sig == SIGINT ? g_prev_int : g_prev_term;
  errno = saved_errno;
  if (prev.sa_flags & SA_SIGINFO) {
    if (prev.sa_sigaction) prev.sa_sigaction(sig, info, ctx);
  } else if (prev.sa_handler == SIG_IGN) {
    return;
  } else if (prev.sa_handler == SIG_DFL) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  } else {
    prev.sa_handler(sig);
  }
}

void install_handlers() {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_sigaction = on_signal;
  sa.sa_flags = SA_SIGINFO | SA_RESTART;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &g_prev_int);
  sigaction(SIGTERM, &sa, &g_prev_term);
}

}  // namespace

namespace {
detail::GpioSlot* slots() {
  static detail::GpioSlot s[kSlots];
  return s;
}
}  // namespace

void GpiodLightConfig::check() const {
  if (chip.empty()) throw DataError("gpiod light: chip must name a gpiochip");
  if (consumer.empty()) throw DataError("gpiod light: consumer must not be empty");
  if (!(max_on_s > 0)) throw DataError("gpiod light: max_on_s must be > 0");
}

GpiodLightConfig gpiod_light_config(const ConfigTable& t) {
  GpiodLightConfig c;
  c.chip = t.string("chip");
  if (c.chip.empty()) t.fail("chip", "must name a gpiochip (name, number, label or /dev path)");
  c.line = static_cast<unsigned>(t.integer("line", Bounds::closed(0, 1023)));
  c.active_low = t.boolean("active_low", c.active_low);
  c.consumer = t.string("consumer", c.consumer);
  if (c.consumer.empty()) t.fail("consumer", "must not be empty");
  c.max_on_s = t.number("max_on_s", c.max_on_s, Bounds::open(0, 86400));
  t.accept("kind");
  t.finish();
  return c;
}

GpiodLight::GpiodLight(GpiodLightConfig config) : config_(std::move(config)) {
  config_.check();
  if (config_.handle_signals) std::call_once(g_handlers_once, install_handlers);
  detail::GpioSlot* s = slots();
  for (int i = 0; i < kSlots && !slot_; ++i) {
    int expected = 0;
    if (s[i].state.compare_exchange_strong(expected, 1)) slot_ = &s[i];
  }
  if (!slot_) throw DeviceError(id(), "too many GPIO lights open at once (at most 16)", false);
  std::string error;
  if (!gpiod_v1::request_output(config_.chip, config_.line, config_.consumer, config_.active_low, 0, &slot_->line,
                                &error)) {
    slot_->state.store(0);
    throw DeviceError(id(), error, false);
  }
  slot_->state.store(2);
  watchdog_ = std::thread([this] { watchdog(); });
}

GpiodLight::~GpiodLight() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
  int expected = 2;
  if (slot_->state.compare_exchange_strong(expected, 1)) {
    gpiod_v1::set_value(slot_->line, 0);
    gpiod_v1::release_line(slot_->line);
  }
  gpiod_v1::close_chip(slot_->line);
  slot_->state.store(0);
}

std::string GpiodLight::id() const {
  return fmt::format("light gpiod {} line {}{}", config_.chip, config_.line, config_.active_low ? " active-low" : "");
}

Result<void> GpiodLight::set_locked(int value, const char* what) {
  if (slot_->state.load() != 2)
    return device_failure(id(), std::string(what) + ": the line was released (signal received)", false);
  if (gpiod_v1::set_value(slot_->line, value) != 0)
    return device_failure(id(), std::string(what) + ": cannot set the line: " + std::strerror(errno), true);
  int back = gpiod_v1::get_value(slot_->line);
  if (back < 0)
    return device_failure(id(), std::string(what) + ": cannot read the line back: " + std::strerror(errno), true);
  if (back != value)
    return device_failure(id(), fmt::format("{}: the LED did not switch (wrote {}, read back {})", what, value, back),
                          true);
  return {};
}

Result<void> GpiodLight::on(double level) {
  if (!(level > 0 && level <= 1))
    return device_failure(id(), fmt::format("on({:g}): level must be in (0, 1]", level), false);
  if (level != 1.0)
    return device_failure(id(), fmt::format("on({:g}): this LED has no dimming (level 1 only)", level), false);
  std::lock_guard lock(mutex_);
  auto r = set_locked(1, "on");
  if (!r) {
    // Never leave the line in an unknown state after a failed switch-on.
    gpiod_v1::set_value(slot_->line, 0);
    lit_ = false;
    return r;
  }
  // A second on() while lit does not extend the on-time of this switch-on.
  if (!lit_) ++on_generation_;
  lit_ = true;
  cv_.notify_all();
  return {};
}

Result<void> GpiodLight::off() {
  std::lock_guard lock(mutex_);
  lit_ = false;
  cv_.notify_all();
  return set_locked(0, "off");
}

Result<bool> GpiodLight::is_on() {
  std::lock_guard lock(mutex_);
  if (slot_->state.load() != 2) return false;
  int v = gpiod_v1::get_value(slot_->line);
  if (v < 0) return device_failure(id(), std::string("cannot read the line: ") + std::strerror(errno), true);
  return v == 1;
}

int GpiodLight::max_on_trips() const {
  std::lock_guard lock(mutex_);
  return trips_;
}

void GpiodLight::watchdog() {
  using Steady = std::chrono::steady_clock;
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (!lit_) {
      cv_.wait(lock);
      continue;
    }
    std::uint64_t gen = on_generation_;
    auto deadline = Steady::now() + std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(config_.max_on_s));
    cv_.wait_until(lock, deadline, [&] { return stopping_ || !lit_ || on_generation_ != gen; });
    if (stopping_) break;
    if (lit_ && on_generation_ == gen && Steady::now() >= deadline) {
      if (slot_->state.load() == 2) gpiod_v1::set_value(slot_->line, 0);
      lit_ = false;
      ++trips_;
      spdlog::warn("{}: on for longer than max_on_s = {:g} s: switched off", id(), config_.max_on_s);
    }
  }
}

std::vector<GpioChipInfo> list_gpiochips() {
  std::vector<GpioChipInfo> out;
  for (const auto& c : gpiod_v1::list_chips()) out.push_back({c.name, c.label, c.lines});
  return out;
}

}  // namespace paintlab::dev
