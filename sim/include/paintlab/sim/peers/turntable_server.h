#pragma once
// The simulated turntable controller: a Modbus server (libmodbus server API) on 127.0.0.1
// TCP and/or on one end of a pty pair (socat) for RTU, implementing a register map
// (devices/register_map.h) over a table that moves with a trapezoidal profile on a
// paintlab::Clock (the sim's virtual clock), and fault switches for tests.
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "paintlab/core/clock.h"
#include "paintlab/devices/register_map.h"

namespace paintlab::sim {

// Faults, switched on per test. Counters count down per request; -1 means "until cleared".
struct ModbusFaults {
  int timeouts = 0;            // requests that get no reply at all
  int drops = 0;               // requests after which the server closes the connection (TCP)
  int exception_code = 0;      // reply with this Modbus exception code ...
  int exceptions = 0;          // ... to this many requests
  int exception_address = -1;  // ... that touch this register (-1: any request)
  int alarm_code = 0;          // non-zero: the controller is in alarm (moves refused)
};

struct TurntableServerOptions {
  dev::RegisterMap map;
  dev::MotionScale scale;
  bool wrap = false;  // 360 deg table: positions reported modulo one turn
  int unit_id = 1;
  // Motion used when the map has no acceleration/deceleration registers.
  double default_accel_deg_s2 = 60.0;
  double initial_angle_deg = 0.0;
};

class TurntableServer {
 public:
  TurntableServer(TurntableServerOptions options, Clock& clock);
  ~TurntableServer();
  TurntableServer(const TurntableServer&) = delete;
  TurntableServer& operator=(const TurntableServer&) = delete;

  // Listens on 127.0.0.1:port (0 = any free port) and returns the port. Throws DeviceError.
  int start_tcp(int port = 0);
  // Creates a pty pair with socat, serves RTU (8N1) on one end and returns the other
  // (/dev/pts/N) for the client. Throws DeviceError when socat is missing or fails.
  std::string start_rtu(int baud = 115200);
  void stop();

  int tcp_port() const { return tcp_port_; }
  const std::string& rtu_client_path() const { return rtu_client_; }

  void set_faults(const ModbusFaults& f);
  ModbusFaults faults() const;

  // The truth: table angle (deg, wrapped when `wrap`) and motion at the clock's now.
  double angle_deg() const;
  bool moving() const;
  bool homed() const;
  // Requests answered, and requests that got the no-reply, drop or exception fault.
  long requests() const { return requests_.load(); }
  long faulted_requests() const { return faulted_.load(); }

 private:
  struct State;
  void serve();
  void handle(void* ctx, int fd, const std::uint8_t* query, int length, bool tcp);

  TurntableServerOptions options_;
  Clock& clock_;
  std::unique_ptr<State> state_;
  mutable std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  int tcp_port_ = 0;
  std::string rtu_client_;
  std::atomic<long> requests_{0};
  std::atomic<long> faulted_{0};
};

}  // namespace paintlab::sim
