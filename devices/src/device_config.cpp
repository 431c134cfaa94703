#include "paintlab/devices/device_config.h"

#include <fmt/format.h>

#include "paintlab/core/error.h"

namespace paintlab::dev {

namespace {
// A view of the section with its own record of read keys: RigConfig accepted the whole
// section, the driver's reader must still reject keys it does not know.
ConfigTable fresh(const DeviceSection& s) {
  if (!s.table) throw DataError("devices." + s.role + ": no table");
  return s.table->with_own_usage();
}
}  // namespace

ModbusTurntableConfig turntable_config(const DeviceSection& section) {
  return modbus_turntable_config(fresh(section), section.kind);
}

GpiodLightConfig gpiod_config(const DeviceSection& section) { return gpiod_light_config(fresh(section)); }

AravisCameraConfig camera_config(const DeviceSection& section, const RigGeometry& geometry) {
  bool sim = section.kind == "sim";
  AravisCameraConfig c = aravis_camera_config(fresh(section), sim);
  // The simulated sensor has the rig's size unless the section says otherwise.
  if (sim && c.width_px == 0) c.width_px = geometry.image_width_px;
  if (sim && c.height_px == 0) c.height_px = geometry.image_height_px;
  // Loopback carries large packets: fewer packets per frame than negotiation picks.
  if (sim && c.packet_size == 0) c.packet_size = 8192;
  return c;
}

SimLightConfig sim_light_config(const DeviceSection& section) {
  ConfigTable t = fresh(section);
  SimLightConfig c;
  c.max_on_s = t.number("max_on_s", c.max_on_s, Bounds::open(0, 86400));
  t.accept("kind");
  t.finish();
  return c;
}

FilterWheelSetup filter_wheel_config(const DeviceSection& section) {
  ConfigTable t = fresh(section);
  FilterWheelSetup w;
  w.kind = section.kind;
  if (w.kind == "serial") {
    w.serial = serial_filter_wheel_config(t);
  } else {
    w.sim_slots = static_cast<int>(t.integer("slots", 6, Bounds::closed(6, 12)));
    if (w.sim_slots != 6 && w.sim_slots != 12) t.fail("slots", "must be 6 or 12 (the wheels' pcount)");
    w.serial.settle_s = t.number("settle_ms", w.serial.settle_s * 1e3, Bounds::non_negative()) * 1e-3;
    // The simulated wheel turns at this speed, and the sweep's minimum counts it.
    w.serial.move_s_per_slot = t.number("move_ms_per_slot", 200.0, Bounds::closed(1.0, 10000.0)) * 1e-3;
  }
  const int max_slot = w.kind == "sim" ? w.sim_slots : 12;
  const char* keys[3] = {"slot_r", "slot_g", "slot_b"};
  for (int c = 0; c < 3; ++c) {
    w.channel_slot[c] = static_cast<int>(t.integer(keys[c], c + 1, Bounds::closed(1, max_slot)));
    for (int k = 0; k < c; ++k)
      if (w.channel_slot[k] == w.channel_slot[c])
        t.fail(keys[c], fmt::format("slot {} is already {}'s: each colour needs its own filter", w.channel_slot[c], keys[k]));
  }
  t.accept("kind");
  t.finish();
  return w;
}

void validate_device_sections(const RigConfig& rig) {
  turntable_config(rig.turntable);
  if (rig.light.kind == "gpiod")
    gpiod_config(rig.light);
  else
    sim_light_config(rig.light);
  camera_config(rig.camera, rig.geometry);
  if (rig.filter_wheel) filter_wheel_config(*rig.filter_wheel);
}

}  // namespace paintlab::dev
