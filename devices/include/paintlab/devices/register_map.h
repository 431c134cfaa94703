#pragma once
// The Modbus register map of a turntable controller, as data. Built-in maps ("oriental-az",
// "leadshine-pr") are tables of addresses, not code; rig.toml may name one, override parts of
// one or give a whole map (docs/devices.md lists every key and address). The same map drives
// the ModbusTurntable driver and the simulated controller in sim/.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/core/config.h"
#include "paintlab/core/json.h"

namespace paintlab::dev {

// A quantity held in one (16-bit) or two (32-bit) consecutive holding registers.
struct RegisterField {
  int address = -1;  // holding register address (0-based, as on the wire); -1 = absent
  int words = 2;     // 1 or 2 registers
  bool is_signed = true;

  bool present() const { return address >= 0; }
};

// A write that makes the controller do something (start, home, stop, alarm reset).
// The controller acts when the written value contains all bits of `value`; a `pulse`
// action is written as `value` and then 0 (an input bit that acts on its rising edge).
struct RegisterAction {
  RegisterField reg;
  std::int64_t value = 0;
  bool pulse = false;

  bool present() const { return reg.present(); }
};

// The status word and the meaning of its bits (bit index 0..31, -1 = not provided).
struct StatusWord {
  RegisterField reg;
  int ready_bit = -1;        // accepts commands
  int alarm_bit = -1;        // an alarm is present
  std::int64_t moving_mask = 0;  // any of these bits set = moving / busy
  int in_position_bit = -1;  // -1: in position = not moving
  int homed_bit = -1;        // return-to-home completed
};

enum class SpeedUnit { CountsPerS, Rpm };          // rpm: motor revolutions per minute
enum class AccelUnit { CountsPerS2, MsPer1000Rpm };  // ms per 1000 rpm of speed change

struct RegisterMap {
  std::string name;
  bool high_word_first = true;  // 32-bit values: upper word in the lower address

  // The positioning block.
  RegisterField operation_number;  // written with 0 when present (AZ: direct-data op. no.)
  RegisterField operation_type;    // written with op_absolute or op_wrap_absolute
  std::int64_t op_absolute = 1;
  std::int64_t op_wrap_absolute = -1;  // -1: the controller has no wrap-around mode
  RegisterField target_position;       // counts (motor steps)
  RegisterField speed;                 // in speed_unit
  RegisterField acceleration;          // in accel_unit
  RegisterField deceleration;
  RegisterField current;               // written with current_value when present
  std::int64_t current_value = 0;
  SpeedUnit speed_unit = SpeedUnit::CountsPerS;
  AccelUnit accel_unit = AccelUnit::CountsPerS2;
  double speed_scale = 1.0;  // register units per speed_unit
  double accel_scale = 1.0;  // register units per accel_unit

  RegisterAction start;
  RegisterAction home;
  RegisterAction stop;
  RegisterAction alarm_reset;

  StatusWord status;
  RegisterField alarm_code;         // present alarm code (0 = none)
  RegisterField encoder_position;   // feedback position, counts
  RegisterField command_position;   // optional

  // Every register address the map uses (each 32-bit field contributes two).
  std::vector<int> addresses() const;
  // Throws DataError naming the map and the first broken rule (missing required field,
  // overlapping fields, bits out of range).
  void check() const;
  Json to_json() const;
};

// Names of the built-in maps.
std::vector<std::string> builtin_register_maps();
// A built-in map; throws DataError for an unknown name.
RegisterMap builtin_register_map(const std::string& name);

// Reads `register_map` from a turntable table: either a string naming a built-in map, or a
// table (optionally `base = "<built-in>"` plus overrides). Unknown keys are ConfigErrors.
RegisterMap register_map_from_config(const ConfigTable& turntable_table);

// Packs a value into 1 or 2 registers in the map's word order, and back.
std::vector<std::uint16_t> encode_field(const RegisterMap& map, const RegisterField& f, std::int64_t value);
std::int64_t decode_field(const RegisterMap& map, const RegisterField& f, const std::uint16_t* regs);

// Motion units: conversions between the table's deg/s and deg/s^2 and register values.
struct MotionScale {
  double counts_per_deg = 100.0;        // table angle to controller counts (gearing included)
  double motor_counts_per_rev = 10000;  // for rpm units
};
std::int64_t speed_to_register(const RegisterMap& map, const MotionScale& s, double speed_deg_s);
double speed_from_register(const RegisterMap& map, const MotionScale& s, std::int64_t value);
std::int64_t accel_to_register(const RegisterMap& map, const MotionScale& s, double accel_deg_s2);
double accel_from_register(const RegisterMap& map, const MotionScale& s, std::int64_t value);

}  // namespace paintlab::dev
