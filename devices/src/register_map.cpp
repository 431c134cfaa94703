#include "paintlab/devices/register_map.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>
#include <toml++/toml.h>

#include "paintlab/core/error.h"

namespace paintlab::dev {

namespace {

RegisterField field(int address, int words, bool is_signed = true) { return RegisterField{address, words, is_signed}; }

// Oriental Motor AZ series (built-in controller, Modbus RTU), direct data operation.
// Addresses: see docs/devices.md for the sources and what was verified.
RegisterMap oriental_az() {
  RegisterMap m;
  m.name = "oriental-az";
  m.high_word_first = true;
  m.operation_number = field(0x0058, 2);
  m.operation_type = field(0x005A, 2);
  m.op_absolute = 1;
  m.op_wrap_absolute = 8;
  m.target_position = field(0x005C, 2);
  m.speed = field(0x005E, 2);         // Hz = steps/s
  m.acceleration = field(0x0060, 2);  // starting/changing speed rate, 0.001 kHz/s = 1 step/s^2
  m.deceleration = field(0x0062, 2);  // stopping deceleration, same unit
  m.current = field(0x0064, 2);       // operating current, 1 = 0.1 %
  m.current_value = 1000;
  m.speed_unit = SpeedUnit::CountsPerS;
  m.accel_unit = AccelUnit::CountsPerS2;
  // Direct data operation trigger: 1 = every item of the block above takes effect and the
  // operation starts.
  m.start = RegisterAction{field(0x0066, 2), 1, false};
  // Driver input command (lower word): ZHOME bit 4, STOP bit 5, ALM-RST bit 7; the driver acts
  // on the OFF -> ON edge.
  m.home = RegisterAction{field(0x007D, 1, false), 0x0010, true};
  m.stop = RegisterAction{field(0x007D, 1, false), 0x0020, true};
  m.alarm_reset = RegisterAction{field(0x007D, 1, false), 0x0080, true};
  // Driver output status (lower word): HOME-END 4, READY 5, ALM-A 7, SYS-BSY 8, MOVE 13, IN-POS 14.
  m.status.reg = field(0x007F, 1, false);
  m.status.ready_bit = 5;
  m.status.alarm_bit = 7;
  m.status.moving_mask = (1 << 8) | (1 << 13);
  m.status.in_position_bit = 14;
  m.status.homed_bit = 4;
  m.alarm_code = field(0x0080, 2, false);
  m.encoder_position = field(0x0120, 2);  // detection (feedback) position
  m.command_position = field(0x0122, 2);
  return m;
}

// Leadshine RS-485 stepper drives in PR (internal position) mode, path PR0.
RegisterMap leadshine_pr() {
  RegisterMap m;
  m.name = "leadshine-pr";
  m.high_word_first = true;
  m.operation_type = field(0x6200, 1, false);  // PR0 mode word
  m.op_absolute = 0x0001;
  m.op_wrap_absolute = -1;
  m.target_position = field(0x6201, 2);     // PR0 position, high word at 0x6201
  m.speed = field(0x6203, 1, false);        // rpm
  m.acceleration = field(0x6204, 1, false);  // ms / 1000 rpm
  m.deceleration = field(0x6205, 1, false);
  m.speed_unit = SpeedUnit::Rpm;
  m.accel_unit = AccelUnit::MsPer1000Rpm;
  // Pr8.02 trigger register: 0x10 + n runs path n, 0x20 homes, 0x40 stops.
  m.start = RegisterAction{field(0x6002, 1, false), 0x0010, false};
  m.home = RegisterAction{field(0x6002, 1, false), 0x0020, false};
  m.stop = RegisterAction{field(0x6002, 1, false), 0x0040, false};
  // Reading 0x6002 shows the running command (0x01P path, 0x020 homing, 0x040 stop) until done.
  m.status.reg = field(0x6002, 1, false);
  m.status.moving_mask = 0x0070;
  m.alarm_code = field(0x2203, 1, false);
  m.encoder_position = field(0x602A, 2);
  return m;
}

[[noreturn]] void map_error(const RegisterMap& m, const std::string& msg) {
  throw DataError("register map '" + m.name + "': " + msg);
}

struct NamedField {
  const char* name;
  const RegisterField* f;
};

std::vector<NamedField> data_fields(const RegisterMap& m) {
  return {{"operation_number", &m.operation_number}, {"operation_type", &m.operation_type},
          {"target_position", &m.target_position},   {"speed", &m.speed},
          {"acceleration", &m.acceleration},         {"deceleration", &m.deceleration},
          {"current", &m.current},                   {"alarm_code", &m.alarm_code},
          {"encoder_position", &m.encoder_position}, {"command_position", &m.command_position}};
}

Json field_json(const RegisterField& f) {
  if (!f.present()) return nullptr;
  return Json{{"address", f.address}, {"words", f.words}, {"signed", f.is_signed}};
}

Json action_json(const RegisterAction& a) {
  if (!a.present()) return nullptr;
  Json j = field_json(a.reg);
  j["value"] = a.value;
  j["pulse"] = a.pulse;
  return j;
}

const char* speed_unit_name(SpeedUnit u) { return u == SpeedUnit::Rpm ? "rpm" : "counts-per-s"; }
const char* accel_unit_name(AccelUnit u) { return u == AccelUnit::MsPer1000Rpm ? "ms-per-1000rpm" : "counts-per-s2"; }

// ---- reading a map from rig.toml ----

bool is_none(const ConfigTable& t, std::string_view key) {
  const toml::node* n = t.raw().get(key);
  if (n && n->is_string() && n->value<std::string>() == "none") {
    t.accept(key);
    return true;
  }
  return false;
}

void read_field(const ConfigTable& t, std::string_view key, RegisterField& f, bool signed_default) {
  if (!t.has(key)) return;
  if (is_none(t, key)) {
    f = RegisterField{};
    return;
  }
  ConfigTable ft = t.table(key);
  f.address = static_cast<int>(ft.integer("address", Bounds::closed(0, 65535)));
  f.words = static_cast<int>(ft.integer("words", f.present() ? f.words : 2, Bounds::closed(1, 2)));
  f.is_signed = ft.boolean("signed", signed_default);
  if (f.address + f.words - 1 > 65535) ft.fail("address", "the field runs past register 65535");
  ft.finish();
}

void read_action(const ConfigTable& t, std::string_view key, RegisterAction& a) {
  if (!t.has(key)) return;
  if (is_none(t, key)) {
    a = RegisterAction{};
    return;
  }
  ConfigTable at = t.table(key);
  a.reg.address = static_cast<int>(at.integer("address", Bounds::closed(0, 65535)));
  a.reg.words = static_cast<int>(at.integer("words", 1, Bounds::closed(1, 2)));
  a.reg.is_signed = false;
  a.value = at.integer("value", Bounds::closed(1, 4294967295.0));
  a.pulse = at.boolean("pulse", false);
  at.finish();
}

void read_status(const ConfigTable& t, StatusWord& s) {
  if (!t.has("status")) return;
  ConfigTable st = t.table("status");
  s.reg.address = static_cast<int>(st.integer("address", Bounds::closed(0, 65535)));
  s.reg.words = static_cast<int>(st.integer("words", 1, Bounds::closed(1, 2)));
  s.reg.is_signed = false;
  auto bit = [&](const char* key, int& out) {
    out = static_cast<int>(st.integer(key, out, Bounds::closed(-1, 31)));
  };
  bit("ready_bit", s.ready_bit);
  bit("alarm_bit", s.alarm_bit);
  bit("in_position_bit", s.in_position_bit);
  bit("homed_bit", s.homed_bit);
  s.moving_mask = st.integer("moving_mask", s.moving_mask, Bounds::closed(0, 4294967295.0));
  st.finish();
}

}  // namespace

std::vector<int> RegisterMap::addresses() const {
  std::vector<int> out;
  auto add = [&](const RegisterField& f) {
    if (!f.present()) return;
    for (int i = 0; i < f.words; ++i) out.push_back(f.address + i);
  };
  for (const auto& nf : data_fields(*this)) add(*nf.f);
  for (const RegisterAction* a : {&start, &home, &stop, &alarm_reset}) add(a->reg);
  add(status.reg);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void RegisterMap::check() const {
  auto check_field = [&](const char* name, const RegisterField& f) {
    if (!f.present()) return;
    if (f.words != 1 && f.words != 2) map_error(*this, fmt::format("{}: words must be 1 or 2", name));
    if (f.address + f.words - 1 > 65535) map_error(*this, fmt::format("{}: address out of range", name));
  };
  auto fields = data_fields(*this);
  for (const auto& nf : fields) check_field(nf.name, *nf.f);
  if (!target_position.present()) map_error(*this, "target_position is required");
  if (!speed.present()) map_error(*this, "speed is required");
  if (!encoder_position.present()) map_error(*this, "encoder_position is required");
  if (!status.reg.present()) map_error(*this, "status is required");
  if (!start.present()) map_error(*this, "start is required");
  // Data fields must not overlap one another (actions and the status word may share one
  // register: many controllers read back a command register as status).
  for (std::size_t i = 0; i < fields.size(); ++i)
    for (std::size_t j = i + 1; j < fields.size(); ++j) {
      const RegisterField& a = *fields[i].f;
      const RegisterField& b = *fields[j].f;
      if (!a.present() || !b.present()) continue;
      if (a.address < b.address + b.words && b.address < a.address + a.words)
        map_error(*this, fmt::format("{} (0x{:04X}) overlaps {} (0x{:04X})", fields[i].name, a.address,
                                     fields[j].name, b.address));
    }
  int bits = 16 * status.reg.words;
  for (int b : {status.ready_bit, status.alarm_bit, status.in_position_bit, status.homed_bit})
    if (b >= bits) map_error(*this, fmt::format("status bit {} does not fit a {}-bit status word", b, bits));
  if (status.moving_mask == 0 && status.in_position_bit < 0)
    map_error(*this, "status needs moving_mask or in_position_bit to tell when a move has ended");
  if (status.moving_mask >> bits) map_error(*this, "status moving_mask has bits beyond the status word");
  if (speed_scale <= 0 || accel_scale <= 0) map_error(*this, "speed_scale and accel_scale must be > 0");
}

Json RegisterMap::to_json() const {
  Json j{{"name", name},
         {"word_order", high_word_first ? "high-first" : "low-first"},
         {"op_absolute", op_absolute},
         {"op_wrap_absolute", op_wrap_absolute},
         {"current_value", current_value},
         {"speed_unit", speed_unit_name(speed_unit)},
         {"accel_unit", accel_unit_name(accel_unit)},
         {"speed_scale", speed_scale},
         {"accel_scale", accel_scale},
         {"start", action_json(start)},
         {"home", action_json(home)},
         {"stop", action_json(stop)},
         {"alarm_reset", action_json(alarm_reset)}};
  for (const auto& nf : data_fields(*this)) j[nf.name] = field_json(*nf.f);
  Json st = field_json(status.reg);
  st["ready_bit"] = status.ready_bit;
  st["alarm_bit"] = status.alarm_bit;
  st["moving_mask"] = status.moving_mask;
  st["in_position_bit"] = status.in_position_bit;
  st["homed_bit"] = status.homed_bit;
  j["status"] = st;
  return j;
}

std::vector<std::string> builtin_register_maps() { return {"oriental-az", "leadshine-pr"}; }

RegisterMap builtin_register_map(const std::string& name) {
  if (name == "oriental-az") return oriental_az();
  if (name == "leadshine-pr") return leadshine_pr();
  throw DataError("unknown register map '" + name + "' (built-in maps: oriental-az, leadshine-pr)");
}

RegisterMap register_map_from_config(const ConfigTable& t) {
  const toml::node* n = t.raw().get("register_map");
  if (!n) return oriental_az();
  if (n->is_string()) {
    std::string name = t.choice("register_map", builtin_register_maps());
    return builtin_register_map(name);
  }
  ConfigTable mt = t.table("register_map");
  RegisterMap m;
  if (auto base = mt.maybe_string("base")) {
    m = builtin_register_map(mt.choice("base", builtin_register_maps()));
    m.name = *base + "+rig";
  } else {
    m.name = "custom";
  }
  m.name = mt.string("name", m.name);
  m.high_word_first = mt.choice("word_order", m.high_word_first ? "high-first" : "low-first",
                                {"high-first", "low-first"}) == "high-first";
  read_field(mt, "operation_number", m.operation_number, false);
  read_field(mt, "operation_type", m.operation_type, false);
  m.op_absolute = mt.integer("op_absolute", m.op_absolute, Bounds::closed(0, 4294967295.0));
  m.op_wrap_absolute = mt.integer("op_wrap_absolute", m.op_wrap_absolute, Bounds::closed(-1, 4294967295.0));
  read_field(mt, "target_position", m.target_position, true);
  read_field(mt, "speed", m.speed, false);
  read_field(mt, "acceleration", m.acceleration, false);
  read_field(mt, "deceleration", m.deceleration, false);
  read_field(mt, "current", m.current, false);
  m.current_value = mt.integer("current_value", m.current_value, Bounds::closed(0, 4294967295.0));
  m.speed_unit = mt.choice("speed_unit", speed_unit_name(m.speed_unit), {"counts-per-s", "rpm"}) == "rpm"
                     ? SpeedUnit::Rpm
                     : SpeedUnit::CountsPerS;
  m.accel_unit =
      mt.choice("accel_unit", accel_unit_name(m.accel_unit), {"counts-per-s2", "ms-per-1000rpm"}) == "ms-per-1000rpm"
          ? AccelUnit::MsPer1000Rpm
          : AccelUnit::CountsPerS2;
  m.speed_scale = mt.number("speed_scale", m.speed_scale, Bounds::positive());
  m.accel_scale = mt.number("accel_scale", m.accel_scale, Bounds::positive());
  read_action(mt, "start", m.start);
  read_action(mt, "home", m.home);
  read_action(mt, "stop", m.stop);
  read_action(mt, "alarm_reset", m.alarm_reset);
  read_status(mt, m.status);
  read_field(mt, "alarm_code", m.alarm_code, false);
  read_field(mt, "encoder_position", m.encoder_position, true);
  read_field(mt, "command_position", m.command_position, true);
  mt.finish();
  try {
    m.check();
  } catch (const DataError& e) {
    mt.fail("", e.what());
  }
  return m;
}

std::vector<std::uint16_t> encode_field(const RegisterMap& map, const RegisterField& f, std::int64_t value) {
  auto v = static_cast<std::uint32_t>(value);
  if (f.words == 1) return {static_cast<std::uint16_t>(v & 0xFFFF)};
  auto hi = static_cast<std::uint16_t>(v >> 16), lo = static_cast<std::uint16_t>(v & 0xFFFF);
  return map.high_word_first ? std::vector<std::uint16_t>{hi, lo} : std::vector<std::uint16_t>{lo, hi};
}

std::int64_t decode_field(const RegisterMap& map, const RegisterField& f, const std::uint16_t* regs) {
  if (f.words == 1) return f.is_signed ? static_cast<std::int16_t>(regs[0]) : regs[0];
  std::uint32_t hi = map.high_word_first ? regs[0] : regs[1];
  std::uint32_t lo = map.high_word_first ? regs[1] : regs[0];
  std::uint32_t v = (hi << 16) | lo;
  return f.is_signed ? static_cast<std::int32_t>(v) : static_cast<std::int64_t>(v);
}

namespace {
double counts_per_s_per_rpm(const MotionScale& s) { return s.motor_counts_per_rev / 60.0; }
}  // namespace

std::int64_t speed_to_register(const RegisterMap& map, const MotionScale& s, double speed_deg_s) {
  double counts_s = speed_deg_s * s.counts_per_deg;
  double unit = map.speed_unit == SpeedUnit::Rpm ? counts_s / counts_per_s_per_rpm(s) : counts_s;
  return std::max<std::int64_t>(1, std::llround(unit * map.speed_scale));
}

double speed_from_register(const RegisterMap& map, const MotionScale& s, std::int64_t value) {
  double unit = static_cast<double>(value) / map.speed_scale;
  double counts_s = map.speed_unit == SpeedUnit::Rpm ? unit * counts_per_s_per_rpm(s) : unit;
  return counts_s / s.counts_per_deg;
}

std::int64_t accel_to_register(const RegisterMap& map, const MotionScale& s, double accel_deg_s2) {
  double counts_s2 = accel_deg_s2 * s.counts_per_deg;
  double unit;
  if (map.accel_unit == AccelUnit::MsPer1000Rpm) {
    // Time in ms to change the speed by 1000 rpm.
    double rpm_per_s = counts_s2 / counts_per_s_per_rpm(s);
    unit = 1000.0 / rpm_per_s * 1000.0;
  } else {
    unit = counts_s2;
  }
  return std::max<std::int64_t>(1, std::llround(unit * map.accel_scale));
}

double accel_from_register(const RegisterMap& map, const MotionScale& s, std::int64_t value) {
  double unit = static_cast<double>(std::max<std::int64_t>(1, value)) / map.accel_scale;
  double counts_s2;
  if (map.accel_unit == AccelUnit::MsPer1000Rpm) {
    double rpm_per_s = 1000.0 / (unit / 1000.0);
    counts_s2 = rpm_per_s * counts_per_s_per_rpm(s);
  } else {
    counts_s2 = unit;
  }
  return counts_s2 / s.counts_per_deg;
}

}  // namespace paintlab::dev
