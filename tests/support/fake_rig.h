#pragma once
// Small in-memory devices for unit tests of code that sees only the device interfaces
// (acquisition, calibration capture): a clock that jumps when slept on, a table that moves
// at a constant speed on that clock, a light whose state the camera's frames show, and a
// camera whose frames are a function of exposure and light. Faults are switched per test.
#include <cmath>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

#include "paintlab/core/clock.h"
#include "paintlab/core/image.h"
#include "paintlab/core/result.h"
#include "paintlab/devices/camera.h"
#include "paintlab/devices/light.h"
#include "paintlab/devices/turntable.h"

namespace paintlab::test {

// The one test clock: now_s() moves only when someone sleeps on it, at once (thread-safe),
// so motion, settling and exposures take their physical durations in virtual time only.
class FakeClock final : public Clock {
 public:
  explicit FakeClock(double start_s = 1000.0) : t_(start_s) {}
  double now_s() const override {
    std::lock_guard lock(mutex_);
    return t_;
  }
  void sleep_s(double s) override {
    std::lock_guard lock(mutex_);
    if (s > 0) t_ += s;
  }

 private:
  mutable std::mutex mutex_;
  double t_;
};

// A table that moves at `speed` deg/s on the clock; `fail_moves` moves fail (retryable).
class FakeTable final : public dev::Turntable {
 public:
  explicit FakeTable(Clock& c) : clock_(c) {}
  std::string id() const override { return "turntable test"; }
  Result<void> home() override { return move_to(0.0); }
  Result<void> move_to(double a) override {
    ++moves;
    if (fail_moves > 0) {
      --fail_moves;
      return device_failure(id(), "timeout (register 0x005C)", true);
    }
    from_ = position();
    target_ = a;
    t0_ = clock_.now_s();
    return {};
  }
  Result<double> angle_deg() override { return position(); }
  Result<dev::TurntableStatus> status() override {
    dev::TurntableStatus s;
    s.ready = true;
    s.moving = position() != target_;
    s.in_position = !s.moving;
    s.homed = true;
    s.angle_deg = position();
    return s;
  }
  Result<double> wait_settled(double) override {
    clock_.sleep_s(move_time_s(from_, target_) - (clock_.now_s() - t0_));
    return position();
  }
  Result<void> stop() override {
    target_ = position();
    from_ = target_;
    ++stops;
    return {};
  }
  Result<void> reset_alarm() override { return {}; }
  double move_time_s(double a, double b) const override { return std::abs(b - a) / speed; }

  int fail_moves = 0;
  int moves = 0;
  int stops = 0;
  double speed = 30.0;

 private:
  double position() const {
    double d = target_ - from_;
    double moved = speed * (clock_.now_s() - t0_);
    if (moved >= std::abs(d)) return target_;
    return from_ + std::copysign(moved, d);
  }
  Clock& clock_;
  double from_ = 0, target_ = 0, t0_ = 0;
};

// A light; `stuck` keeps its state whatever is commanded.
class FakeLight final : public dev::Light {
 public:
  std::string id() const override { return "light test"; }
  Result<void> on(double) override {
    if (!stuck) state = true;
    ++switch_ons;
    return {};
  }
  Result<void> off() override {
    if (!stuck) state = false;
    ++switch_offs;
    return {};
  }
  Result<bool> is_on() override { return state; }
  bool has_level() const override { return false; }
  bool state = false;
  bool stuck = false;
  int switch_ons = 0;
  int switch_offs = 0;
};

// A Mono16 camera (or `format`) whose frames are `width` x `height` pixels of value
// `pixel(exposure_s, light_on)` (default: 100 + exposure in 10 us units with the light on,
// 5 with it off). Exposures are applied in 10 us increments within [1e-5, 1] s. Captures
// take the exposure plus the readout on the clock. `lose_frames` captures fail
// (retryable), `gone` makes every capture fail for good.
class FakeCamera final : public dev::Camera {
 public:
  FakeCamera(Clock& c, FakeLight& l) : clock_(c), light_(l) {}
  std::string id() const override { return "camera test"; }
  std::string serial() const override { return "TEST-1"; }
  Result<dev::ExposureRange> exposure_range() override { return range; }
  Result<double> set_exposure(double s) override {
    exposure_ = std::clamp(std::round(s / 1e-5) * 1e-5, range.min_s, range.max_s);  // 10 us increments
    return exposure_;
  }
  Result<double> set_gain_db(double g) override {
    gain_db = g;
    return g;
  }
  Result<void> set_pixel_format(dev::PixelFormat f) override {
    format = f;
    return {};
  }
  Result<dev::PixelFormat> pixel_format() override { return format; }
  double readout_s() const override { return 0.02; }
  Result<dev::Frame> capture(double timeout_s) override {
    last_timeout_s = timeout_s;
    if (on_capture) on_capture(captures);
    ++captures;
    if (gone) return device_failure(id(), "camera disappeared", false);
    if (lose_frames > 0) {
      --lose_frames;
      clock_.sleep_s(exposure_ + readout_s());
      return device_failure(id(), "frame incomplete (missing packets)", true);
    }
    clock_.sleep_s(exposure_ + readout_s());
    dev::Frame f;
    const double full = std::ldexp(1.0, dev::bit_depth(format)) - 1.0;
    const double v = pixel ? pixel(exposure_, light_.state) : (light_.state ? 100 + exposure_ * 1e5 : 5);
    f.pixels = Image<std::uint16_t>(width, height, 1, static_cast<std::uint16_t>(std::clamp(std::round(v), 0.0, full)));
    if (image)
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          f.pixels.at(x, y) =
              static_cast<std::uint16_t>(std::clamp(std::round(image(x, y, exposure_, light_.state)), 0.0, full));
    f.meta.exposure_s = exposure_;
    f.meta.format = format;
    f.meta.frame_id = 65400 + captures;
    f.meta.timestamp_ns = static_cast<std::uint64_t>(clock_.now_s() * 1e9);
    return f;
  }
  double exposure_s() const { return exposure_; }

  std::function<void(int)> on_capture;
  std::function<double(double exposure_s, bool light_on)> pixel;
  // When set: each pixel's value instead of pixel() (a scene with a shape, e.g. a sphere).
  std::function<double(int x, int y, double exposure_s, bool light_on)> image;
  dev::ExposureRange range{1e-5, 1.0};
  dev::PixelFormat format = dev::PixelFormat::Mono16;
  int width = 8, height = 6;
  int captures = 0;
  int lose_frames = 0;
  bool gone = false;
  double gain_db = 0.0;
  double last_timeout_s = 0.0;

 private:
  Clock& clock_;
  FakeLight& light_;
  double exposure_ = 1e-3;
};

}  // namespace paintlab::test
