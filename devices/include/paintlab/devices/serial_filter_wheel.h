#pragma once
// SerialFilterWheel: a filter wheel on a serial line (USB-serial adapter) with the ASCII
// command set of Thorlabs' FW102C/FW212C (docs/devices.md): lower-case keywords, "key=value"
// commands and "key?" queries ended by a carriage return; the wheel echoes each line, sends
// the answer of a query on its own line and then its prompt ">"; a bad keyword or argument
// gives "Command error ..." before the prompt. Used: `*idn?`, `pos=N`, `pos?`, `pcount?`.
//
// Every exchange has a response timeout and is retried (after flushing the line) on a
// timeout or a garbled echo; a "Command error" is not retried. move_to() sends pos=N and
// polls pos? until the wheel reports N or `move_timeout_s` passes (then it resends, up to
// `retries` times), and waits `settle_s` on the rig's clock after arriving.
#include <memory>
#include <string>

#include "paintlab/core/clock.h"
#include "paintlab/core/config.h"
#include "paintlab/devices/filter_wheel.h"

namespace paintlab::dev {

struct SerialFilterWheelConfig {
  std::string port;                 // /dev/ttyUSB0, /dev/serial/by-id/..., /dev/pts/N
  int baud = 115200;                // the FW102C's default (8N1, no flow control)
  double response_timeout_s = 1.0;  // per exchange
  int retries = 2;                  // extra attempts after a timeout, garbled echo or missed slot
  double move_timeout_s = 5.0;      // for one move to report its slot
  double poll_interval_s = 0.01;    // pos? polling while moving (an exchange takes ~1 ms at 115200 baud)
  double settle_s = 0.2;            // after the slot is reached (vibration)
  // The wheel's time to turn by one slot (its datasheet's); 0: unknown. Only the sweep's
  // physical minimum uses it (min_move_s); moves are always read back.
  double move_s_per_slot = 0.0;

  void check() const;  // OptionError naming the field, value and rule
};

// Reads a [devices.filter_wheel] table (kind "serial"): port, baud, response_timeout_ms,
// retries, move_timeout_ms, settle_ms, move_ms_per_slot. ConfigError naming file, line and key.
SerialFilterWheelConfig serial_filter_wheel_config(const ConfigTable& table);

class SerialFilterWheel final : public FilterWheel {
 public:
  // Opens and configures the port (raw, 8N1, no flow control). DeviceError when it cannot.
  explicit SerialFilterWheel(SerialFilterWheelConfig config, Clock& clock = system_clock());
  ~SerialFilterWheel() override;
  SerialFilterWheel(const SerialFilterWheel&) = delete;
  SerialFilterWheel& operator=(const SerialFilterWheel&) = delete;

  std::string id() const override;
  Result<std::string> identify() override;
  Result<int> slot_count() override;
  Result<int> position() override;
  Result<void> move_to(int slot) override;
  // steps x move_s_per_slot + settle_s, steps the shorter way round the wheel's pcount slots
  // (known after the first move); 0 when move_s_per_slot is 0.
  double min_move_s(int from_slot, int to_slot) const override;

  int retry_count() const { return retries_; }  // exchanges and moves retried so far

 private:
  // Sends `line`, returns the answer lines between the echo and the prompt.
  Result<std::string> exchange(const std::string& line);
  Result<std::string> exchange_once(const std::string& line);
  Result<int> query_int(const std::string& query);

  SerialFilterWheelConfig config_;
  Clock& clock_;
  int fd_ = -1;
  int retries_ = 0;
  int slots_ = 0;  // cached pcount
};

}  // namespace paintlab::dev
