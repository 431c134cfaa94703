#include "paintlab/sim/peers/sim_filter_wheel.h"

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>

#include "paintlab/core/error.h"

namespace paintlab::sim {

SimFilterWheel::SimFilterWheel(SimFilterWheelOptions options, Clock& clock)
    : options_(std::move(options)), clock_(clock) {
  if (options_.slots < 1 || options_.start_slot < 1 || options_.start_slot > options_.slots)
    throw DataError(fmt::format("sim filter wheel: start slot {} of {} slots", options_.start_slot, options_.slots));
  from_ = to_ = options_.start_slot;
  master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0)
    throw IoError("/dev/ptmx", "no pseudo-terminal for the simulated filter wheel", errno);
  char name[128];
  if (::ptsname_r(master_, name, sizeof name) != 0) throw IoError("/dev/ptmx", "ptsname failed");
  port_ = name;
  slave_ = ::open(port_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (slave_ < 0) throw IoError(port_, "cannot open the simulated filter wheel's line", errno);
  termios tio{};
  ::tcgetattr(slave_, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(slave_, TCSANOW, &tio);
  thread_ = std::thread([this] { serve(); });
}

SimFilterWheel::~SimFilterWheel() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

int SimFilterWheel::position_locked() const { return clock_.now_s() >= arrival_s_ ? to_ : from_; }

int SimFilterWheel::position() const {
  std::lock_guard lock(mutex_);
  return position_locked();
}

int SimFilterWheel::moves() const {
  std::lock_guard lock(mutex_);
  return moves_;
}

int SimFilterWheel::lines() const {
  std::lock_guard lock(mutex_);
  return lines_;
}

void SimFilterWheel::set_faults(const FilterWheelFaults& f) {
  std::lock_guard lock(mutex_);
  faults_ = f;
}

std::string SimFilterWheel::answer(const std::string& line) {
  if (line == "*idn?") return options_.identity;
  if (line == "pcount?") return std::to_string(options_.slots);
  if (line == "pos?") return std::to_string(position_locked());
  if (line.rfind("pos=", 0) == 0) {
    int n = 0;
    const char* b = line.data() + 4;
    const char* e = line.data() + line.size();
    const auto [end, ec] = std::from_chars(b, e, n);
    if (ec != std::errc() || end != e || n < 1 || n > options_.slots) return "Command error CMD_ARG_INVALID";
    const int here = position_locked();
    const int d = std::abs(n - here), steps = std::min(d, options_.slots - d);
    from_ = here;
    to_ = faults_.stuck ? here : n;
    arrival_s_ = clock_.now_s() + steps * options_.move_s_per_slot;
    ++moves_;
    return "";
  }
  return "Command error CMD_NOT_DEFINED";
}

void SimFilterWheel::serve() {
  std::string pending;
  while (!stop_) {
    pollfd p{master_, POLLIN, 0};
    const int r = ::poll(&p, 1, 20);
    if (r <= 0 || !(p.revents & POLLIN)) continue;
    char buf[256];
    const ssize_t n = ::read(master_, buf, sizeof buf);
    if (n <= 0) continue;
    pending.append(buf, static_cast<std::size_t>(n));
    std::size_t cr;
    while ((cr = pending.find('\r')) != std::string::npos) {
      const std::string line = pending.substr(0, cr);
      pending.erase(0, cr + 1);
      std::string reply;
      {
        std::lock_guard lock(mutex_);
        ++lines_;
        if (faults_.silent > 0) {
          --faults_.silent;
          continue;
        }
        std::string echo = line;
        if (faults_.garbled > 0) {
          --faults_.garbled;
          echo = "p" + std::string(line.size() > 1 ? line.size() - 1 : 1, '#');
        }
        std::string a;
        if (faults_.refused > 0) {
          --faults_.refused;
          a = "Command error CMD_NOT_DEFINED";
        } else {
          a = answer(line);
        }
        reply = echo + "\r" + (a.empty() ? "" : a + "\r") + ">";
      }
      std::size_t sent = 0;
      while (sent < reply.size()) {
        const ssize_t w = ::write(master_, reply.data() + sent, reply.size() - sent);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) break;
        sent += static_cast<std::size_t>(w);
      }
    }
  }
}

}  // namespace paintlab::sim
