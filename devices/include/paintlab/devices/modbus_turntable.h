#pragma once
// ModbusTurntable: a turntable controller reached over Modbus TCP or RTU (libmodbus), with
// its register map as data (register_map.h). Every transaction has a response timeout and
// is retried with exponential backoff on timeouts and lost connections (reconnecting);
// Modbus exception replies become DeviceErrors naming the register and the exception.
// All waiting goes through a paintlab::Clock, so the simulated rig's virtual clock works.
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "paintlab/core/clock.h"
#include "paintlab/core/config.h"
#include "paintlab/devices/register_map.h"
#include "paintlab/devices/turntable.h"

namespace paintlab::dev {

struct ModbusTurntableConfig {
  enum class Transport { Tcp, Rtu };
  Transport transport = Transport::Tcp;
  // TCP
  std::string host = "127.0.0.1";
  int port = 502;
  // RTU
  std::string serial_device;  // /dev/ttyUSB0, /dev/pts/N
  int baud = 115200;
  char parity = 'E';          // 'N', 'E', 'O'
  int data_bits = 8;
  int stop_bits = 1;

  int unit_id = 1;
  RegisterMap map;
  MotionScale scale;              // counts_per_deg, motor_counts_per_rev

  double response_timeout_s = 1.0;  // per request (libmodbus' 0.5 s default is too short for some)
  int retries = 3;                  // extra attempts after a timeout or a lost connection
  double backoff_s = 0.05;          // first retry delay; doubles each attempt
  double speed_deg_s = 30.0;
  double accel_deg_s2 = 60.0;
  double decel_deg_s2 = 60.0;
  double min_angle_deg = -360.0;    // limits of move_to (ignored when wrap is on)
  double max_angle_deg = 360.0;
  bool wrap = false;                // a 360 deg table: angles taken modulo 360
  double position_tolerance_deg = 0.05;  // settled: |encoder - target| within this
  double poll_interval_s = 0.02;    // status polling while waiting
  double settle_timeout_s = 30.0;   // default for wait_settled callers that use it

  // Throws ConfigError-free DataError naming the first violated rule.
  void check() const;
  std::string endpoint() const;  // "127.0.0.1:502" or "/dev/ttyUSB0 115200 8E1"
};

// Reads a [devices.turntable] table of kind "modbus-tcp", "modbus-rtu" or "sim" (the
// simulated controller; `transport` = "tcp" or "rtu", endpoint filled in later). Keys in
// docs/devices.md; unknown keys are ConfigErrors naming file, line and key.
ModbusTurntableConfig modbus_turntable_config(const ConfigTable& table, const std::string& kind);

class ModbusTurntable final : public Turntable {
 public:
  // Does not connect yet: connect() does, and every call reconnects when needed.
  ModbusTurntable(ModbusTurntableConfig config, Clock& clock = system_clock());
  ~ModbusTurntable() override;
  ModbusTurntable(const ModbusTurntable&) = delete;
  ModbusTurntable& operator=(const ModbusTurntable&) = delete;

  // Opens the connection and reads the status once (reachability check).
  Result<void> connect();

  std::string id() const override;
  Result<void> home() override;
  Result<void> move_to(double angle_deg) override;
  Result<double> angle_deg() override;
  Result<TurntableStatus> status() override;
  Result<double> wait_settled(double timeout_s) override;
  Result<void> stop() override;
  Result<void> reset_alarm() override;
  double move_time_s(double from_deg, double to_deg) const override;

  const ModbusTurntableConfig& config() const { return config_; }
  // The angle a move_to(angle) actually commands (snapped to counts, wrapped): what the
  // table will read when settled.
  double snapped_angle_deg(double angle_deg) const;
  // Transactions that needed a retry, and reconnects, since construction.
  int retry_count() const { return retries_; }
  int reconnect_count() const { return reconnects_; }

 private:
  struct Ctx;
  Result<void> ensure_connected();
  void disconnect();
  Result<void> write_field(const char* what, const RegisterField& f, std::int64_t value);
  Result<std::int64_t> read_field(const char* what, const RegisterField& f);
  Result<void> do_action(const char* what, const RegisterAction& a);
  Result<TurntableStatus> read_status_locked();
  double counts_to_deg(std::int64_t counts) const;
  std::int64_t deg_to_counts(double deg) const;
  template <class F>
  auto transact(const char* what, int address, bool is_write, F&& op) -> Result<decltype(op())>;

  ModbusTurntableConfig config_;
  Clock& clock_;
  std::unique_ptr<Ctx> ctx_;
  std::mutex mutex_;
  std::optional<double> target_deg_;  // last commanded target (snapped)
  bool homing_ = false;
  bool homed_ = false;
  int retries_ = 0;
  int reconnects_ = 0;
};

}  // namespace paintlab::dev
