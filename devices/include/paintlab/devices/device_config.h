#pragma once
// The device sections of rig.toml ([devices.turntable], [devices.light], [devices.camera]):
// kind-specific keys read into the drivers' configs. core's RigConfig keeps each section as
// a ConfigTable and checks only `kind`; these functions check the rest (unknown keys, types,
// ranges), with errors naming file, line and key. Keys: docs/devices.md.
#include "paintlab/core/rig.h"
#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/gpiod_light.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/devices/serial_filter_wheel.h"

#include <array>

namespace paintlab::dev {

// kind "modbus-tcp", "modbus-rtu" or "sim" (the simulated controller: transport = "tcp" or
// "rtu"; the endpoint is filled in when the simulated peer is up).
ModbusTurntableConfig turntable_config(const DeviceSection& section);
// kind "gpiod".
GpiodLightConfig gpiod_config(const DeviceSection& section);
// kind "aravis", or "sim" (id 127.0.0.1, the region from the rig's geometry unless given).
AravisCameraConfig camera_config(const DeviceSection& section, const RigGeometry& geometry);

// kind "sim" of the light.
struct SimLightConfig {
  double max_on_s = 60.0;
};
SimLightConfig sim_light_config(const DeviceSection& section);

// [devices.filter_wheel] of kind "serial" (a wheel on a serial line: port, baud, timeouts,
// settle_ms; devices/serial_filter_wheel.h) or "sim" (a simulated wheel on a pty pair:
// `slots` 6 or 12, settle_ms); both give the slot of each colour filter, slot_r, slot_g,
// slot_b (1, 2, 3 by default; distinct, within the wheel's slots when it says how many).
struct FilterWheelSetup {
  std::string kind;
  SerialFilterWheelConfig serial;       // kind serial; kind sim: the timeouts and settle only
  int sim_slots = 6;                    // kind sim: the simulated wheel's pcount
  std::array<int, 3> channel_slot{1, 2, 3};  // R, G, B
};
FilterWheelSetup filter_wheel_config(const DeviceSection& section);

// Validates every device section of the rig (what `paintlab rig validate` runs).
// Throws ConfigError for the first bad key.
void validate_device_sections(const RigConfig& rig);

}  // namespace paintlab::dev
