#include "paintlab/sim/peers/turntable_server.h"

#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <set>
#include <vector>

#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include "paintlab/devices/motion_profile.h"

extern char** environ;

namespace paintlab::sim {

namespace {
constexpr const char* kName = "sim turntable server";
}

struct TurntableServer::State {
  modbus_mapping_t* mapping = nullptr;
  int first_address = 0;
  std::set<int> valid;

  modbus_t* tcp = nullptr;
  int listen_fd = -1;
  std::vector<int> clients;
  modbus_t* rtu = nullptr;
  pid_t socat_pid = -1;
  int socat_err_fd = -1;
  int wake[2] = {-1, -1};

  // Motion, in controller counts (unwrapped inside one move).
  bool active = false;
  double pos0 = 0.0;
  double target = 0.0;
  double t0 = 0.0;
  double dir = 1.0;
  dev::TrapezoidProfile profile;
  bool homing = false;
  bool homed = false;
  std::int64_t running_value = 0;  // the action value shown in a shared status/command register
  ModbusFaults faults;

  ~State() {
    if (mapping) modbus_mapping_free(mapping);
  }

  std::uint16_t* reg(int address) { return &mapping->tab_registers[address - first_address]; }
};

TurntableServer::TurntableServer(TurntableServerOptions options, Clock& clock)
    : options_(std::move(options)), clock_(clock), state_(std::make_unique<State>()) {
  options_.map.check();
  auto addrs = options_.map.addresses();
  state_->valid.insert(addrs.begin(), addrs.end());
  state_->first_address = addrs.front();
  int count = addrs.back() - addrs.front() + 1;
  state_->mapping = modbus_mapping_new_start_address(0, 0, 0, 0, static_cast<unsigned>(addrs.front()),
                                                     static_cast<unsigned>(count), 0, 0);
  if (!state_->mapping) throw DeviceError(kName, "cannot allocate the register mapping", false);
  double c = options_.initial_angle_deg * options_.scale.counts_per_deg;
  state_->pos0 = state_->target = c;
  if (pipe2(state_->wake, O_CLOEXEC | O_NONBLOCK) != 0) throw DeviceError(kName, "cannot create a pipe", false);
}

TurntableServer::~TurntableServer() {
  stop();
  close(state_->wake[0]);
  close(state_->wake[1]);
}

int TurntableServer::start_tcp(int port) {
  std::lock_guard lock(mutex_);
  if (state_->tcp) throw DeviceError(kName, "TCP already started", false);
  state_->tcp = modbus_new_tcp("127.0.0.1", port);
  if (!state_->tcp) throw DeviceError(kName, std::string("cannot create the TCP context: ") + modbus_strerror(errno), false);
  int fd = modbus_tcp_listen(state_->tcp, 8);
  if (fd < 0) {
    int e = errno;
    modbus_free(state_->tcp);
    state_->tcp = nullptr;
    throw DeviceError(kName, fmt::format("cannot listen on 127.0.0.1:{}: {}", port, modbus_strerror(e)), false);
  }
  fcntl(fd, F_SETFD, FD_CLOEXEC);
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  state_->listen_fd = fd;
  tcp_port_ = ntohs(addr.sin_port);
  if (!thread_.joinable()) thread_ = std::thread([this] { serve(); });
  else if (write(state_->wake[1], "w", 1) < 0) spdlog::debug("{}: wake pipe full", kName);
  return tcp_port_;
}

std::string TurntableServer::start_rtu(int baud) {
  std::lock_guard lock(mutex_);
  if (state_->rtu) throw DeviceError(kName, "RTU already started", false);
  int err_pipe[2];
  if (pipe2(err_pipe, O_CLOEXEC) != 0) throw DeviceError(kName, "cannot create a pipe", false);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, err_pipe[1], STDERR_FILENO);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  const char* argv[] = {"socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0", nullptr};
  // socat must not inherit a blocked SIGTERM (`sim serve` blocks it to sigwait for it).
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGTERM);
  sigaddset(&defaults, SIGPIPE);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  pid_t pid = -1;
  int rc = posix_spawnp(&pid, "socat", &fa, &attr, const_cast<char* const*>(argv), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  close(err_pipe[1]);
  if (rc != 0) {
    close(err_pipe[0]);
    throw DeviceError(kName, std::string("cannot start socat (Debian package socat): ") + std::strerror(rc), false);
  }
  // socat -d -d prints "PTY is /dev/pts/N" for each end, then starts its transfer loop.
  std::vector<std::string> ptys;
  std::string buf;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (ptys.size() < 2 && std::chrono::steady_clock::now() < deadline) {
    pollfd p{err_pipe[0], POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char tmp[512];
    ssize_t n = read(err_pipe[0], tmp, sizeof tmp);
    if (n <= 0) break;
    buf.append(tmp, static_cast<std::size_t>(n));
    std::size_t nl;
    while ((nl = buf.find('\n')) != std::string::npos) {
      std::string line = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      auto at = line.find("PTY is ");
      if (at != std::string::npos) ptys.push_back(line.substr(at + 7));
    }
  }
  if (ptys.size() < 2) {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
    close(err_pipe[0]);
    throw DeviceError(kName, "socat did not report a pty pair within 5 s", false);
  }
  state_->socat_pid = pid;
  state_->socat_err_fd = err_pipe[0];
  state_->rtu = modbus_new_rtu(ptys[0].c_str(), baud, 'N', 8, 1);
  if (!state_->rtu || modbus_set_slave(state_->rtu, options_.unit_id) != 0 || modbus_connect(state_->rtu) != 0) {
    std::string m = modbus_strerror(errno);
    if (state_->rtu) modbus_free(state_->rtu);
    state_->rtu = nullptr;
    throw DeviceError(kName, "cannot open " + ptys[0] + " for RTU: " + m, false);
  }
  rtu_client_ = ptys[1];
  if (!thread_.joinable()) thread_ = std::thread([this] { serve(); });
  else if (write(state_->wake[1], "w", 1) < 0) spdlog::debug("{}: wake pipe full", kName);
  return rtu_client_;
}

void TurntableServer::stop() {
  stop_.store(true);
  if (state_->wake[1] >= 0 && write(state_->wake[1], "s", 1) < 0) spdlog::debug("{}: wake pipe full", kName);
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  for (int fd : state_->clients) close(fd);
  state_->clients.clear();
  if (state_->listen_fd >= 0) close(state_->listen_fd);
  state_->listen_fd = -1;
  if (state_->tcp) modbus_free(state_->tcp);
  state_->tcp = nullptr;
  if (state_->rtu) {
    modbus_close(state_->rtu);
    modbus_free(state_->rtu);
  }
  state_->rtu = nullptr;
  if (state_->socat_pid > 0) {
    kill(state_->socat_pid, SIGTERM);
    bool gone = false;
    for (int i = 0; i < 200 && !gone; ++i) {
      gone = waitpid(state_->socat_pid, nullptr, WNOHANG) == state_->socat_pid;
      if (!gone) usleep(10000);
    }
    if (!gone) {
      kill(state_->socat_pid, SIGKILL);
      waitpid(state_->socat_pid, nullptr, 0);
    }
  }
  state_->socat_pid = -1;
  if (state_->socat_err_fd >= 0) close(state_->socat_err_fd);
  state_->socat_err_fd = -1;
}

void TurntableServer::set_faults(const ModbusFaults& f) {
  std::lock_guard lock(mutex_);
  state_->faults = f;
}

ModbusFaults TurntableServer::faults() const {
  std::lock_guard lock(mutex_);
  return state_->faults;
}

namespace {

// Position (counts) of the motion at time t: the target once the move's time is up.
double position_at(double t, bool active, double pos0, double target, double t0,
                   double dir, const dev::TrapezoidProfile& p) {
  if (!active || t - t0 >= p.duration()) return target;
  return pos0 + dir * p.position_at(t - t0);
}

}  // namespace

double TurntableServer::angle_deg() const {
  std::lock_guard lock(mutex_);
  const State& s = *state_;
  double c = position_at(clock_.now_s(), s.active, s.pos0, s.target, s.t0, s.dir, s.profile);
  double deg = c / options_.scale.counts_per_deg;
  return options_.wrap ? dev::wrap_deg(deg) : deg;
}

bool TurntableServer::moving() const {
  std::lock_guard lock(mutex_);
  return state_->active && clock_.now_s() - state_->t0 < state_->profile.duration();
}

bool TurntableServer::homed() const {
  std::lock_guard lock(mutex_);
  return state_->homed;
}

void TurntableServer::serve() {
  std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH > MODBUS_RTU_MAX_ADU_LENGTH ? MODBUS_TCP_MAX_ADU_LENGTH
                                                                                       : MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_.load()) {
    std::vector<pollfd> fds;
    std::vector<int> kinds;  // 0 wake, 1 listen, 2 client, 3 rtu, 4 socat stderr
    {
      std::lock_guard lock(mutex_);
      fds.push_back({state_->wake[0], POLLIN, 0});
      kinds.push_back(0);
      if (state_->listen_fd >= 0) {
        fds.push_back({state_->listen_fd, POLLIN, 0});
        kinds.push_back(1);
      }
      for (int c : state_->clients) {
        fds.push_back({c, POLLIN, 0});
        kinds.push_back(2);
      }
      if (state_->rtu) {
        fds.push_back({modbus_get_socket(state_->rtu), POLLIN, 0});
        kinds.push_back(3);
      }
      if (state_->socat_err_fd >= 0) {
        fds.push_back({state_->socat_err_fd, POLLIN, 0});
        kinds.push_back(4);
      }
    }
    int n = poll(fds.data(), fds.size(), 200);
    if (n <= 0) continue;
    for (std::size_t i = 0; i < fds.size(); ++i) {
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      switch (kinds[i]) {
        case 0: {
          char b[16];
          while (read(state_->wake[0], b, sizeof b) > 0) {
          }
          break;
        }
        case 1: {
          int c = accept4(fds[i].fd, nullptr, nullptr, SOCK_CLOEXEC);
          if (c >= 0) {
            std::lock_guard lock(mutex_);
            state_->clients.push_back(c);
          }
          break;
        }
        case 2: {
          std::lock_guard lock(mutex_);
          modbus_set_socket(state_->tcp, fds[i].fd);
          int rc = modbus_receive(state_->tcp, query.data());
          if (rc > 0) handle(state_->tcp, fds[i].fd, query.data(), rc, true);
          else if (rc == -1) {
            close(fds[i].fd);
            std::erase(state_->clients, fds[i].fd);
          }
          break;
        }
        case 3: {
          std::lock_guard lock(mutex_);
          if (!state_->rtu) break;
          int rc = modbus_receive(state_->rtu, query.data());
          if (rc > 0) handle(state_->rtu, -1, query.data(), rc, false);
          else if (rc == -1) modbus_flush(state_->rtu);
          break;
        }
        case 4: {
          char b[512];
          if (read(fds[i].fd, b, sizeof b) <= 0) {
            std::lock_guard lock(mutex_);
            close(state_->socat_err_fd);
            state_->socat_err_fd = -1;
          }
          break;
        }
        default: break;
      }
    }
  }
}

// Called with mutex_ held.
void TurntableServer::handle(void* vctx, int fd, const std::uint8_t* q, int length, bool tcp) {
  auto* ctx = static_cast<modbus_t*>(vctx);
  State& s = *state_;
  const dev::RegisterMap& m = options_.map;
  const double now = clock_.now_s();
  const int h = modbus_get_header_length(ctx);
  if (tcp && q[h - 1] != options_.unit_id && q[h - 1] != 0xFF) return;  // other unit: no reply
  const int function = q[h];
  const int address = (q[h + 1] << 8) | q[h + 2];
  int count = 1;
  if (function == MODBUS_FC_READ_HOLDING_REGISTERS || function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS)
    count = (q[h + 3] << 8) | q[h + 4];

  auto take = [](int& counter) {
    if (counter == 0) return false;
    if (counter > 0) --counter;
    return true;
  };
  if (take(s.faults.timeouts)) {
    ++faulted_;
    return;
  }
  if (take(s.faults.drops)) {
    ++faulted_;
    if (tcp && fd >= 0) {
      close(fd);
      std::erase(s.clients, fd);
    }
    return;
  }
  bool touches = s.faults.exception_address < 0 ||
                 (s.faults.exception_address >= address && s.faults.exception_address < address + count);
  if (s.faults.exception_code != 0 && touches && take(s.faults.exceptions)) {
    ++faulted_;
    modbus_reply_exception(ctx, q, static_cast<unsigned>(s.faults.exception_code));
    return;
  }
  if (function != MODBUS_FC_READ_HOLDING_REGISTERS && function != MODBUS_FC_WRITE_SINGLE_REGISTER &&
      function != MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
    modbus_reply_exception(ctx, q, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
    return;
  }
  for (int a = address; a < address + count; ++a)
    if (!s.valid.count(a)) {
      modbus_reply_exception(ctx, q, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      return;
    }

  // Motion state and outputs at `now`.
  const double rev = std::llround(360.0 * options_.scale.counts_per_deg);
  auto current = [&] { return position_at(now, s.active, s.pos0, s.target, s.t0, s.dir, s.profile); };
  auto finish_if_done = [&] {
    if (s.active && now - s.t0 >= s.profile.duration()) {
      s.active = false;
      s.pos0 = s.target;
      if (s.homing) s.homed = true;
      s.homing = false;
      s.running_value = 0;
    }
  };
  auto field = [&](const dev::RegisterField& f) { return dev::decode_field(m, f, s.reg(f.address)); };
  auto set_field = [&](const dev::RegisterField& f, std::int64_t v) {
    if (!f.present()) return;
    auto regs = dev::encode_field(m, f, v);
    std::copy(regs.begin(), regs.end(), s.reg(f.address));
  };
  auto report_counts = [&](double c) {
    auto v = static_cast<std::int64_t>(std::llround(c));
    if (options_.wrap) {
      auto r = static_cast<std::int64_t>(rev);
      v = ((v % r) + r) % r;
    }
    return v;
  };
  auto update_outputs = [&] {
    finish_if_done();
    bool moving = s.active;
    bool alarm = s.faults.alarm_code != 0;
    set_field(m.encoder_position, report_counts(current()));
    set_field(m.command_position, report_counts(moving ? s.target : current()));
    set_field(m.alarm_code, s.faults.alarm_code);
    std::int64_t word = 0;
    auto set_bit = [&](int b, bool on) {
      if (b >= 0 && on) word |= (std::int64_t{1} << b);
    };
    set_bit(m.status.ready_bit, !moving && !alarm);
    set_bit(m.status.alarm_bit, alarm);
    set_bit(m.status.in_position_bit, !moving);
    set_bit(m.status.homed_bit, s.homed && !moving);
    if (moving) word |= s.running_value != 0 ? s.running_value : m.status.moving_mask;
    set_field(m.status.reg, word);
  };
  update_outputs();

  // Values of the action registers before a write, to see edges.
  struct Act {
    const dev::RegisterAction* a;
    std::int64_t before;
  };
  std::vector<Act> acts;
  for (const dev::RegisterAction* a : {&m.start, &m.home, &m.stop, &m.alarm_reset})
    if (a->present()) acts.push_back({a, field(a->reg)});

  ++requests_;
  if (modbus_reply(ctx, q, length, s.mapping) < 0) return;
  if (function == MODBUS_FC_READ_HOLDING_REGISTERS) return;

  auto written = [&](const dev::RegisterField& f) { return f.address < address + count && address < f.address + f.words; };
  std::set<int> to_clear;
  for (const Act& act : acts) {
    const dev::RegisterAction& a = *act.a;
    if (!written(a.reg)) continue;
    std::int64_t v = field(a.reg);
    bool on = (v & a.value) == a.value;
    bool was = (act.before & a.value) == a.value;
    if (!on || (a.pulse && was)) continue;
    if (!a.pulse) to_clear.insert(a.reg.address);
    const double cur = current();
    auto start_motion = [&](double target_counts, std::int64_t shown) {
      double cps = dev::speed_from_register(m, options_.scale, m.speed.present() ? field(m.speed) : 0) *
                   options_.scale.counts_per_deg;
      if (!(cps > 0)) return;
      double acc = m.acceleration.present()
                       ? dev::accel_from_register(m, options_.scale, field(m.acceleration)) * options_.scale.counts_per_deg
                       : options_.default_accel_deg_s2 * options_.scale.counts_per_deg;
      double dec = m.deceleration.present()
                       ? dev::accel_from_register(m, options_.scale, field(m.deceleration)) * options_.scale.counts_per_deg
                       : acc;
      double from = cur;
      if (options_.wrap) {
        from = std::fmod(from, rev);
        if (from < 0) from += rev;
      }
      s.pos0 = from;
      s.target = target_counts;
      s.dir = target_counts >= from ? 1.0 : -1.0;
      s.profile = dev::TrapezoidProfile{std::abs(target_counts - from), cps, acc, dec};
      s.t0 = now;
      s.active = true;
      s.running_value = a.reg.address == m.status.reg.address ? shown : 0;
    };
    if (&a == &m.start) {
      if (s.faults.alarm_code != 0) continue;
      double t = static_cast<double>(field(m.target_position));
      if (options_.wrap) {
        t = std::fmod(t, rev);
        if (t < 0) t += rev;
      }
      start_motion(t, a.value);
      s.homing = false;
    } else if (&a == &m.home) {
      if (s.faults.alarm_code != 0) continue;
      start_motion(0.0, a.value);
      s.homing = true;
      s.homed = false;
    } else if (&a == &m.stop) {
      // The simulated controller stops at once (no deceleration ramp).
      s.pos0 = s.target = cur;
      s.active = false;
      s.homing = false;
      s.running_value = 0;
    } else if (&a == &m.alarm_reset) {
      s.faults.alarm_code = 0;
    }
  }
  for (int addr : to_clear)
    if (addr != m.status.reg.address) *s.reg(addr) = 0;
  // A non-pulse action register that is also the status word shows the status again.
  update_outputs();
  if (m.start.present() && !m.start.pulse && m.start.reg.words == 2) {
    // Both words of a 32-bit trigger return to 0.
    if (to_clear.count(m.start.reg.address)) *s.reg(m.start.reg.address + 1) = 0;
  }
}

}  // namespace paintlab::sim
