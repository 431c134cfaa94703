#include "paintlab/devices/serial_filter_wheel.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <charconv>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "paintlab/core/error.h"

namespace paintlab::dev {

namespace {

constexpr const char* kCommandError = "Command error";

speed_t baud_constant(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    default: return B0;
  }
}

// The lines of `text` split at CR or LF, empty ones left out.
std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : text) {
    if (c == '\r' || c == '\n') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace

void SerialFilterWheelConfig::check() const {
  if (port.empty()) throw OptionError("SerialFilterWheelConfig::port", "\"\"", "a serial device path");
  if (baud_constant(baud) == B0)
    throw OptionError("SerialFilterWheelConfig::baud", std::to_string(baud), "9600, 19200, 38400, 57600 or 115200");
  if (!(response_timeout_s > 0))
    throw OptionError("SerialFilterWheelConfig::response_timeout_s", fmt::format("{}", response_timeout_s), "> 0");
  if (retries < 0 || retries > 20)
    throw OptionError("SerialFilterWheelConfig::retries", std::to_string(retries), "0..20");
  if (!(move_timeout_s > 0))
    throw OptionError("SerialFilterWheelConfig::move_timeout_s", fmt::format("{}", move_timeout_s), "> 0");
  if (!(poll_interval_s > 0))
    throw OptionError("SerialFilterWheelConfig::poll_interval_s", fmt::format("{}", poll_interval_s), "> 0");
  if (!(settle_s >= 0)) throw OptionError("SerialFilterWheelConfig::settle_s", fmt::format("{}", settle_s), ">= 0");
  if (!(move_s_per_slot >= 0))
    throw OptionError("SerialFilterWheelConfig::move_s_per_slot", fmt::format("{}", move_s_per_slot), ">= 0");
}

SerialFilterWheelConfig serial_filter_wheel_config(const ConfigTable& t) {
  SerialFilterWheelConfig c;
  c.port = t.string("port");
  c.baud = static_cast<int>(t.integer("baud", 115200, Bounds::closed(9600, 115200)));
  if (baud_constant(c.baud) == B0) t.fail("baud", "must be 9600, 19200, 38400, 57600 or 115200");
  c.response_timeout_s = t.number("response_timeout_ms", 1000.0, Bounds::positive()) * 1e-3;
  c.retries = static_cast<int>(t.integer("retries", 2, Bounds::closed(0, 20)));
  c.move_timeout_s = t.number("move_timeout_ms", 5000.0, Bounds::positive()) * 1e-3;
  c.settle_s = t.number("settle_ms", 200.0, Bounds::non_negative()) * 1e-3;
  c.move_s_per_slot = t.number("move_ms_per_slot", 0.0, Bounds::closed(0.0, 10000.0)) * 1e-3;
  return c;
}

SerialFilterWheel::SerialFilterWheel(SerialFilterWheelConfig config, Clock& clock)
    : config_(std::move(config)), clock_(clock) {
  config_.check();
  fd_ = ::open(config_.port.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (fd_ < 0) throw DeviceError(id(), fmt::format("cannot open: {}", std::strerror(errno)), false);
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    throw DeviceError(id(), fmt::format("not a serial line: {}", std::strerror(e)), false);
  }
  ::cfmakeraw(&tio);  // 8 data bits, no parity, no echo, no line editing
  tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  ::cfsetispeed(&tio, baud_constant(config_.baud));
  ::cfsetospeed(&tio, baud_constant(config_.baud));
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    throw DeviceError(id(), fmt::format("cannot configure the line: {}", std::strerror(e)), false);
  }
  ::tcflush(fd_, TCIOFLUSH);
}

SerialFilterWheel::~SerialFilterWheel() {
  if (fd_ >= 0) ::close(fd_);
}

std::string SerialFilterWheel::id() const { return "filter wheel serial " + config_.port; }

Result<std::string> SerialFilterWheel::exchange_once(const std::string& line) {
  ::tcflush(fd_, TCIFLUSH);  // nothing stale is taken for the answer
  const std::string out = line + "\r";
  std::size_t sent = 0;
  while (sent < out.size()) {
    const ssize_t n = ::write(fd_, out.data() + sent, out.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return device_failure(id(), fmt::format("'{}': write failed: {}", line, std::strerror(errno)), true);
    sent += static_cast<std::size_t>(n);
  }
  // Read until the prompt: a '>' that ends what arrived (after the echo and any answer).
  std::string in;
  const double deadline = clock_.now_s() + config_.response_timeout_s;
  for (;;) {
    const std::size_t cr = in.find_first_of("\r\n");
    if (cr != std::string::npos && !in.empty() && in.back() == '>') break;
    // The line itself waits in real time (the wheel answers at its own pace); the deadline
    // is also checked on the rig's clock so that a virtual clock cannot stretch it.
    const double left = deadline - clock_.now_s();
    pollfd p{fd_, POLLIN, 0};
    const int ms = static_cast<int>(std::ceil(std::max(0.0, std::min(left, config_.response_timeout_s)) * 1e3));
    const int r = ::poll(&p, 1, ms);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) return device_failure(id(), fmt::format("'{}': poll failed: {}", line, std::strerror(errno)), true);
    if (r == 0 || left <= 0)
      return device_failure(id(), fmt::format("'{}': no prompt within {:g} s (got '{}')", line,
                                              config_.response_timeout_s, in),
                            true);
    char buf[256];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n < 0) return device_failure(id(), fmt::format("'{}': read failed: {}", line, std::strerror(errno)), true);
    if (n == 0) return device_failure(id(), fmt::format("'{}': the line closed", line), true);
    in.append(buf, static_cast<std::size_t>(n));
    if (in.size() > 4096) return device_failure(id(), fmt::format("'{}': no prompt in 4 KiB of answer", line), true);
  }
  in.pop_back();  // the prompt
  std::vector<std::string> got = lines_of(in);
  if (got.empty() || got.front() != line)
    return device_failure(id(), fmt::format("'{}': garbled echo '{}'", line, got.empty() ? "" : got.front()), true);
  std::string answer;
  for (std::size_t i = 1; i < got.size(); ++i) {
    if (got[i].rfind(kCommandError, 0) == 0)
      return device_failure(id(), fmt::format("'{}' refused: {}", line, got[i]), false);
    answer += (answer.empty() ? "" : "\n") + got[i];
  }
  return answer;
}

Result<std::string> SerialFilterWheel::exchange(const std::string& line) {
  Result<std::string> r = exchange_once(line);
  for (int attempt = 0; !r && r.error().retryable() && attempt < config_.retries; ++attempt) {
    ++retries_;
    spdlog::debug("{}: {}; retrying", id(), r.error().what());
    r = exchange_once(line);
  }
  return r;
}

Result<int> SerialFilterWheel::query_int(const std::string& query) {
  Result<std::string> r = exchange(query);
  if (!r) return tl::unexpected(r.error());
  int v = 0;
  const std::string& s = *r;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size())
    return device_failure(id(), fmt::format("'{}': answer '{}' is not a number", query, s), true);
  return v;
}

Result<std::string> SerialFilterWheel::identify() { return exchange("*idn?"); }

Result<int> SerialFilterWheel::slot_count() {
  if (slots_ > 0) return slots_;
  Result<int> n = query_int("pcount?");
  if (n && *n < 1) return device_failure(id(), fmt::format("pcount? answered {} slots", *n), false);
  if (n) slots_ = *n;
  return n;
}

Result<int> SerialFilterWheel::position() { return query_int("pos?"); }

double SerialFilterWheel::min_move_s(int from_slot, int to_slot) const {
  if (!(config_.move_s_per_slot > 0.0)) return 0.0;
  int steps = std::abs(to_slot - from_slot);
  if (slots_ > 0) steps = std::min(steps, slots_ - steps);
  return steps > 0 ? steps * config_.move_s_per_slot + config_.settle_s : 0.0;
}

Result<void> SerialFilterWheel::move_to(int slot) {
  Result<int> count = slot_count();
  if (!count) return tl::unexpected(count.error());
  if (slot < 1 || slot > *count)
    return device_failure(id(), fmt::format("slot {} does not exist (the wheel has 1..{})", slot, *count), false);
  std::string last;
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    if (attempt > 0) ++retries_;
    Result<std::string> sent = exchange(fmt::format("pos={}", slot));
    if (!sent) {
      if (!sent.error().retryable()) return tl::unexpected(sent.error());
      last = sent.error().what();
      continue;
    }
    const double deadline = clock_.now_s() + config_.move_timeout_s;
    for (;;) {
      Result<int> at = position();
      if (!at) {
        last = at.error().what();
        if (!at.error().retryable()) return tl::unexpected(at.error());
      } else if (*at == slot) {
        clock_.sleep_s(config_.settle_s);
        return {};
      } else {
        last = fmt::format("at slot {} after {:g} s", *at, config_.move_timeout_s);
      }
      if (clock_.now_s() >= deadline) break;
      clock_.sleep_s(config_.poll_interval_s);
    }
  }
  return device_failure(id(), fmt::format("did not reach slot {} ({} attempts): {}", slot, config_.retries + 1, last),
                        true);
}

}  // namespace paintlab::dev
