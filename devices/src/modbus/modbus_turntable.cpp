#include "paintlab/devices/modbus_turntable.h"

#include <modbus/modbus.h>

#include <cerrno>
#include <cmath>
#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include "paintlab/devices/motion_profile.h"

namespace paintlab::dev {

struct ModbusTurntable::Ctx {
  modbus_t* mb = nullptr;
  bool connected = false;
  ~Ctx() {
    if (mb) {
      if (connected) modbus_close(mb);
      modbus_free(mb);
    }
  }
};

namespace {

bool is_exception(int e) { return e > MODBUS_ENOBASE && e <= EMBXGTAR; }

// Errors after which the link is suspect: close and reconnect before the next attempt.
bool is_link_error(int e) {
  return e == ECONNRESET || e == EPIPE || e == ECONNREFUSED || e == EBADF || e == ENOTCONN || e == EIO ||
         e == ECONNABORTED || e == ENETUNREACH || e == EHOSTUNREACH || e == EMBBADCRC || e == EMBBADDATA ||
         e == EMBMDATA || e == EMBBADSLAVE || e == EMBBADEXC || e == EMBUNKEXC || e == EINVAL;
}

std::string errno_text(int e) {
  if (is_exception(e))
    return fmt::format("Modbus exception 0x{:02X} ({})", e - MODBUS_ENOBASE, modbus_strerror(e));
  if (e == ETIMEDOUT) return "no response (timeout)";
  return modbus_strerror(e);
}

}  // namespace

void ModbusTurntableConfig::check() const {
  auto bad = [](const std::string& m) { throw DataError("modbus turntable config: " + m); };
  if (transport == Transport::Tcp && (port < 1 || port > 65535)) bad("port must be in [1, 65535]");
  if (transport == Transport::Rtu && serial_device.empty()) bad("device (serial port) is required for RTU");
  if (parity != 'N' && parity != 'E' && parity != 'O') bad("parity must be N, E or O");
  if (unit_id < 0 || unit_id > 247) bad("unit_id must be in [0, 247]");
  if (!(response_timeout_s > 0)) bad("response_timeout_ms must be > 0");
  if (retries < 0) bad("retries must be >= 0");
  if (!(speed_deg_s > 0 && accel_deg_s2 > 0 && decel_deg_s2 > 0)) bad("speed and accelerations must be > 0");
  if (!(scale.counts_per_deg > 0)) bad("counts_per_deg must be > 0");
  if (!(max_angle_deg > min_angle_deg)) bad("max_angle_deg must be larger than min_angle_deg");
  if (!(poll_interval_s > 0)) bad("poll_interval_ms must be > 0");
  map.check();
}

std::string ModbusTurntableConfig::endpoint() const {
  if (transport == Transport::Tcp) return fmt::format("{}:{}", host, port);
  return fmt::format("{} {} {}{}{}", serial_device, baud, data_bits, parity, stop_bits);
}

ModbusTurntableConfig modbus_turntable_config(const ConfigTable& t, const std::string& kind) {
  ModbusTurntableConfig c;
  if (kind == "sim") {
    // The simulated controller: the endpoint is known only when the peer is up.
    c.transport = t.choice("transport", "tcp", {"tcp", "rtu"}) == "rtu" ? ModbusTurntableConfig::Transport::Rtu
                                                                        : ModbusTurntableConfig::Transport::Tcp;
    c.parity = 'N';  // a pty keeps no parity
  } else if (kind == "modbus-tcp") {
    c.transport = ModbusTurntableConfig::Transport::Tcp;
  } else if (kind == "modbus-rtu") {
    c.transport = ModbusTurntableConfig::Transport::Rtu;
  } else {
    t.fail("kind", "not a Modbus turntable kind: '" + kind + "'");
  }
  bool simulated = kind == "sim";
  if (!simulated && c.transport == ModbusTurntableConfig::Transport::Tcp) {
    c.host = t.string("host");
    c.port = static_cast<int>(t.integer("port", 502, Bounds::closed(1, 65535)));
  } else if (!simulated) {
    c.serial_device = t.string("device");
    c.baud = static_cast<int>(t.integer("baud", 115200, Bounds::closed(300, 4000000)));
    c.parity = t.choice("parity", "E", {"N", "E", "O"})[0];
    c.data_bits = static_cast<int>(t.integer("data_bits", 8, Bounds::closed(7, 8)));
    c.stop_bits = static_cast<int>(t.integer("stop_bits", 1, Bounds::closed(1, 2)));
  }
  c.unit_id = static_cast<int>(t.integer("unit_id", 1, Bounds::closed(0, 247)));
  c.map = register_map_from_config(t);
  c.scale.counts_per_deg = t.number("counts_per_deg", c.scale.counts_per_deg, Bounds::positive());
  c.scale.motor_counts_per_rev = t.number("motor_counts_per_rev", c.scale.motor_counts_per_rev, Bounds::positive());
  c.response_timeout_s = t.number("response_timeout_ms", 1000, Bounds::closed(1, 60000)) * 1e-3;
  c.retries = static_cast<int>(t.integer("retries", c.retries, Bounds::closed(0, 20)));
  c.backoff_s = t.number("backoff_ms", c.backoff_s * 1e3, Bounds::closed(0, 10000)) * 1e-3;
  c.speed_deg_s = t.number("speed_deg_s", c.speed_deg_s, Bounds::open(0, 3600));
  c.accel_deg_s2 = t.number("accel_deg_s2", c.accel_deg_s2, Bounds::open(0, 1e6));
  c.decel_deg_s2 = t.number("decel_deg_s2", c.accel_deg_s2, Bounds::open(0, 1e6));
  c.wrap = t.boolean("wrap", c.wrap);
  c.min_angle_deg = t.number("min_angle_deg", c.min_angle_deg, Bounds::closed(-1e6, 1e6));
  c.max_angle_deg = t.number("max_angle_deg", c.max_angle_deg, Bounds::closed(-1e6, 1e6));
  if (!(c.max_angle_deg > c.min_angle_deg)) t.fail("max_angle_deg", "must be larger than min_angle_deg");
  c.position_tolerance_deg =
      t.number("position_tolerance_deg", c.position_tolerance_deg, Bounds::open(0, 10));
  c.poll_interval_s = t.number("poll_interval_ms", c.poll_interval_s * 1e3, Bounds::closed(1, 10000)) * 1e-3;
  c.settle_timeout_s = t.number("settle_timeout_s", c.settle_timeout_s, Bounds::open(0, 3600));
  t.accept("kind");
  t.finish();
  return c;
}

ModbusTurntable::ModbusTurntable(ModbusTurntableConfig config, Clock& clock)
    : config_(std::move(config)), clock_(clock), ctx_(std::make_unique<Ctx>()) {
  config_.check();
}

ModbusTurntable::~ModbusTurntable() = default;

std::string ModbusTurntable::id() const {
  return fmt::format("turntable {} {} unit {}",
                     config_.transport == ModbusTurntableConfig::Transport::Tcp ? "modbus-tcp" : "modbus-rtu",
                     config_.endpoint(), config_.unit_id);
}

void ModbusTurntable::disconnect() {
  if (ctx_->mb) {
    if (ctx_->connected) modbus_close(ctx_->mb);
    modbus_free(ctx_->mb);
  }
  ctx_->mb = nullptr;
  ctx_->connected = false;
}

Result<void> ModbusTurntable::ensure_connected() {
  if (ctx_->connected) return {};
  if (!ctx_->mb) {
    if (config_.transport == ModbusTurntableConfig::Transport::Tcp)
      ctx_->mb = modbus_new_tcp(config_.host.c_str(), config_.port);
    else
      ctx_->mb = modbus_new_rtu(config_.serial_device.c_str(), config_.baud, config_.parity, config_.data_bits,
                                config_.stop_bits);
    if (!ctx_->mb) return device_failure(id(), std::string("cannot create Modbus context: ") + modbus_strerror(errno), false);
    modbus_set_slave(ctx_->mb, config_.unit_id);
    auto sec = static_cast<std::uint32_t>(config_.response_timeout_s);
    auto usec = static_cast<std::uint32_t>(std::lround((config_.response_timeout_s - sec) * 1e6));
    if (usec >= 1000000) {
      ++sec;
      usec -= 1000000;
    }
    modbus_set_response_timeout(ctx_->mb, sec, usec);
    modbus_set_error_recovery(ctx_->mb, MODBUS_ERROR_RECOVERY_NONE);
  }
  if (modbus_connect(ctx_->mb) == -1) {
    int e = errno;
    disconnect();
    return device_failure(id(), std::string("cannot connect: ") + modbus_strerror(e), true);
  }
  ctx_->connected = true;
  return {};
}

Result<void> ModbusTurntable::connect() {
  std::lock_guard lock(mutex_);
  auto st = read_status_locked();
  if (!st) return tl::unexpected(st.error());
  return {};
}

template <class F>
auto ModbusTurntable::transact(const char* what, int address, bool is_write, F&& op) -> Result<decltype(op())> {
  std::string where = fmt::format("register 0x{:04X} ({}) {}", address, what, is_write ? "write" : "read");
  std::string last;
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    if (attempt > 0) {
      ++retries_;
      clock_.sleep_s(config_.backoff_s * std::pow(2.0, attempt - 1));
    }
    if (auto c = ensure_connected(); !c) {
      last = c.error().what();
      continue;
    }
    errno = 0;
    auto rc = op();
    if (rc != -1) return rc;
    int e = errno;
    last = errno_text(e);
    if (is_exception(e)) {
      // Busy is the one exception worth another try; the rest are answers.
      if (e == EMBXSBUSY || e == EMBXACK) continue;
      return device_failure(id(), where + ": " + last, false);
    }
    if (e == ETIMEDOUT) {
      spdlog::debug("{}: {}: timeout, attempt {}", id(), where, attempt + 1);
      modbus_flush(ctx_->mb);
      continue;
    }
    if (is_link_error(e) || e == 0) {
      spdlog::debug("{}: {}: {} (reconnecting)", id(), where, last);
      disconnect();
      ++reconnects_;
      continue;
    }
    return device_failure(id(), where + ": " + last, false);
  }
  return device_failure(id(),
                        fmt::format("{}: {} after {} attempts (response timeout {:g} s)", where, last,
                                    config_.retries + 1, config_.response_timeout_s),
                        true);
}

Result<void> ModbusTurntable::write_field(const char* what, const RegisterField& f, std::int64_t value) {
  auto regs = encode_field(config_.map, f, value);
  auto r = transact(what, f.address, true, [&] {
    return modbus_write_registers(ctx_->mb, f.address, static_cast<int>(regs.size()), regs.data());
  });
  if (!r) return tl::unexpected(r.error());
  return {};
}

Result<std::int64_t> ModbusTurntable::read_field(const char* what, const RegisterField& f) {
  std::uint16_t regs[2] = {0, 0};
  auto r = transact(what, f.address, false, [&] { return modbus_read_registers(ctx_->mb, f.address, f.words, regs); });
  if (!r) return tl::unexpected(r.error());
  if (*r != f.words)
    return device_failure(id(), fmt::format("register 0x{:04X} ({}) read: {} registers instead of {}", f.address, what,
                                            *r, f.words),
                          true);
  return decode_field(config_.map, f, regs);
}

Result<void> ModbusTurntable::do_action(const char* what, const RegisterAction& a) {
  if (!a.present())
    return device_failure(id(), fmt::format("register map '{}' has no {} command", config_.map.name, what), false);
  if (auto r = write_field(what, a.reg, a.value); !r) return r;
  if (a.pulse) return write_field(what, a.reg, 0);
  return {};
}

double ModbusTurntable::counts_to_deg(std::int64_t counts) const {
  double deg = static_cast<double>(counts) / config_.scale.counts_per_deg;
  return config_.wrap ? wrap_deg(deg) : deg;
}

std::int64_t ModbusTurntable::deg_to_counts(double deg) const {
  if (config_.wrap) {
    auto rev = std::llround(360.0 * config_.scale.counts_per_deg);
    std::int64_t c = std::llround(wrap_deg(deg) * config_.scale.counts_per_deg);
    return c >= rev ? c - rev : c;
  }
  return std::llround(deg * config_.scale.counts_per_deg);
}

double ModbusTurntable::snapped_angle_deg(double angle_deg) const { return counts_to_deg(deg_to_counts(angle_deg)); }

Result<TurntableStatus> ModbusTurntable::read_status_locked() {
  const RegisterMap& m = config_.map;
  auto word = read_field("status", m.status.reg);
  if (!word) return tl::unexpected(word.error());
  std::int64_t code = 0;
  if (m.alarm_code.present()) {
    auto c = read_field("alarm_code", m.alarm_code);
    if (!c) return tl::unexpected(c.error());
    code = *c;
  }
  auto pos = read_field("encoder_position", m.encoder_position);
  if (!pos) return tl::unexpected(pos.error());
  auto bit = [&](int b) { return b >= 0 && ((*word >> b) & 1) != 0; };
  TurntableStatus s;
  bool alarm = bit(m.status.alarm_bit) || code != 0;
  s.alarm_code = code != 0 ? static_cast<int>(code) : (alarm ? -1 : 0);
  s.moving = (*word & m.status.moving_mask) != 0;
  s.in_position = m.status.in_position_bit >= 0 ? bit(m.status.in_position_bit) : !s.moving;
  s.ready = m.status.ready_bit >= 0 ? bit(m.status.ready_bit) : !alarm;
  s.homed = m.status.homed_bit >= 0 ? bit(m.status.homed_bit) : homed_;
  s.angle_deg = counts_to_deg(*pos);
  return s;
}

Result<TurntableStatus> ModbusTurntable::status() {
  std::lock_guard lock(mutex_);
  return read_status_locked();
}

Result<double> ModbusTurntable::angle_deg() {
  std::lock_guard lock(mutex_);
  auto pos = read_field("encoder_position", config_.map.encoder_position);
  if (!pos) return tl::unexpected(pos.error());
  return counts_to_deg(*pos);
}

Result<void> ModbusTurntable::move_to(double angle_deg) {
  if (!std::isfinite(angle_deg)) return device_failure(id(), "move_to: the angle is not a finite number", false);
  if (!config_.wrap && (angle_deg < config_.min_angle_deg || angle_deg > config_.max_angle_deg))
    return device_failure(id(),
                          fmt::format("move_to({:g} deg): outside the limits [{:g}, {:g}] deg", angle_deg,
                                      config_.min_angle_deg, config_.max_angle_deg),
                          false);
  std::lock_guard lock(mutex_);
  const RegisterMap& m = config_.map;
  auto st = read_status_locked();
  if (!st) return tl::unexpected(st.error());
  if (st->alarm_code != 0)
    return device_failure(id(), fmt::format("move_to({:g} deg): controller alarm code {} (reset the alarm first)",
                                            angle_deg, st->alarm_code),
                          false);
  bool use_wrap = config_.wrap && m.op_wrap_absolute >= 0;
  if (m.operation_number.present())
    if (auto r = write_field("operation_number", m.operation_number, 0); !r) return r;
  if (m.operation_type.present())
    if (auto r = write_field("operation_type", m.operation_type, use_wrap ? m.op_wrap_absolute : m.op_absolute); !r)
      return r;
  std::int64_t counts = deg_to_counts(angle_deg);
  if (auto r = write_field("target_position", m.target_position, counts); !r) return r;
  if (auto r = write_field("speed", m.speed, speed_to_register(m, config_.scale, config_.speed_deg_s)); !r) return r;
  if (m.acceleration.present())
    if (auto r = write_field("acceleration", m.acceleration, accel_to_register(m, config_.scale, config_.accel_deg_s2));
        !r)
      return r;
  if (m.deceleration.present())
    if (auto r = write_field("deceleration", m.deceleration, accel_to_register(m, config_.scale, config_.decel_deg_s2));
        !r)
      return r;
  if (m.current.present())
    if (auto r = write_field("current", m.current, m.current_value); !r) return r;
  if (auto r = do_action("start", m.start); !r) return r;
  target_deg_ = counts_to_deg(counts);
  homing_ = false;
  return {};
}

Result<void> ModbusTurntable::home() {
  std::lock_guard lock(mutex_);
  if (auto r = do_action("home", config_.map.home); !r) return r;
  target_deg_ = 0.0;
  homing_ = true;
  homed_ = false;
  return {};
}

Result<void> ModbusTurntable::stop() {
  std::lock_guard lock(mutex_);
  target_deg_.reset();
  homing_ = false;
  return do_action("stop", config_.map.stop);
}

Result<void> ModbusTurntable::reset_alarm() {
  std::lock_guard lock(mutex_);
  return do_action("alarm_reset", config_.map.alarm_reset);
}

Result<double> ModbusTurntable::wait_settled(double timeout_s) {
  double deadline = clock_.now_s() + timeout_s;
  for (;;) {
    std::unique_lock lock(mutex_);
    auto st = read_status_locked();
    if (!st) return tl::unexpected(st.error());
    if (st->alarm_code != 0)
      return device_failure(id(), fmt::format("alarm code {} while moving (at {:.3f} deg)", st->alarm_code, st->angle_deg),
                            false);
    bool at_target = true;
    if (target_deg_) {
      double d = st->angle_deg - *target_deg_;
      if (config_.wrap) d = std::remainder(d, 360.0);
      at_target = std::abs(d) <= config_.position_tolerance_deg;
    }
    if (!st->moving && st->in_position && at_target) {
      if (homing_) {
        homed_ = true;
        homing_ = false;
      }
      return st->angle_deg;
    }
    lock.unlock();
    double now = clock_.now_s();
    if (now >= deadline)
      return device_failure(
          id(),
          fmt::format("did not settle within {:g} s: at {:.3f} deg, target {}, moving {}, in position {}", timeout_s,
                      st->angle_deg, target_deg_ ? fmt::format("{:.3f} deg", *target_deg_) : std::string("unknown"),
                      st->moving, st->in_position),
          true);
    clock_.sleep_s(std::min(config_.poll_interval_s, deadline - now));
  }
}

double ModbusTurntable::move_time_s(double from_deg, double to_deg) const {
  const RegisterMap& m = config_.map;
  double d;
  if (config_.wrap)
    d = std::abs(snapped_angle_deg(to_deg) - snapped_angle_deg(from_deg));
  else
    d = std::abs(to_deg - from_deg);
  TrapezoidProfile p;
  p.distance = d;
  p.speed = speed_from_register(m, config_.scale, speed_to_register(m, config_.scale, config_.speed_deg_s));
  p.accel = m.acceleration.present()
                ? accel_from_register(m, config_.scale, accel_to_register(m, config_.scale, config_.accel_deg_s2))
                : config_.accel_deg_s2;
  p.decel = m.deceleration.present()
                ? accel_from_register(m, config_.scale, accel_to_register(m, config_.scale, config_.decel_deg_s2))
                : config_.decel_deg_s2;
  return p.duration();
}

}  // namespace paintlab::dev
