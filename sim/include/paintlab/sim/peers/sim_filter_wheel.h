#pragma once
// A simulated filter wheel on a pseudo-terminal pair: it answers the FW102C command set
// (devices/serial_filter_wheel.h) on the master side, and the real driver opens the slave
// (port()) as it would open /dev/ttyUSB0. Moves take `move_s_per_slot` per slot on the rig's
// clock (the shorter way round), so a virtual clock runs them at its pace. Faults for tests:
// lines left unanswered, garbled echoes, refused commands, a wheel that never arrives.
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "paintlab/core/clock.h"

namespace paintlab::sim {

struct SimFilterWheelOptions {
  int slots = 6;                  // pcount: 6 or 12
  int start_slot = 1;
  double move_s_per_slot = 0.2;   // on the clock
  std::string identity = "THORLABS FW102C/FW212C Filter Wheel version 1.07 (paintlab sim)";
};

struct FilterWheelFaults {
  int silent = 0;    // the next N lines get no answer at all
  int garbled = 0;   // the next N lines are echoed wrongly
  int refused = 0;   // the next N lines are answered "Command error CMD_NOT_DEFINED"
  bool stuck = false;  // moves are accepted but the wheel never leaves its slot
};

class SimFilterWheel {
 public:
  // Opens the pty pair and starts answering. DeviceError-free: throws IoError when the
  // system has no pseudo-terminals.
  explicit SimFilterWheel(SimFilterWheelOptions options = {}, Clock& clock = system_clock());
  ~SimFilterWheel();
  SimFilterWheel(const SimFilterWheel&) = delete;
  SimFilterWheel& operator=(const SimFilterWheel&) = delete;

  const std::string& port() const { return port_; }  // /dev/pts/N
  int position() const;   // the slot in front of the lens now
  int moves() const;      // pos=N commands accepted
  int lines() const;      // lines received
  void set_faults(const FilterWheelFaults& f);

 private:
  void serve();
  std::string answer(const std::string& line);  // without echo and prompt; empty: none
  int position_locked() const;

  SimFilterWheelOptions options_;
  Clock& clock_;
  int master_ = -1;
  int slave_ = -1;  // kept open so that the master never sees a hang-up between drivers
  std::string port_;
  mutable std::mutex mutex_;
  int from_ = 1, to_ = 1;  // a move from -> to, arriving at arrival_s_
  double arrival_s_ = 0.0;
  int moves_ = 0;
  int lines_ = 0;
  FilterWheelFaults faults_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace paintlab::sim
