#pragma once
// The one factory that maps rig.toml device kinds to concrete drivers (STYLE.md "Devices").
// Real kinds get their drivers (modbus-tcp / modbus-rtu: ModbusTurntable, gpiod: GpiodLight,
// aravis: AravisCamera, serial: SerialFilterWheel). Kind "sim" starts the simulated peers
// in-process (sim::SimRig) and connects the REAL drivers to them: the turntable over Modbus
// TCP (or RTU on a pty), the camera over GigE Vision, both on 127.0.0.1, the filter wheel on
// a pty pair; the LED is a SimLight.
//
//   RigConfig rig = load_rig("rig.toml");
//   RigDevices d = open_rig_devices(rig);
//   d.turntable->move_to(30); d.turntable->wait_settled(10);
//   d.light->on(); d.camera->set_exposure(0.01); auto frame = d.camera->capture(5);
//   d.clock->now_s();   // the clock the rig runs on (sim: the world's virtual clock)
#include <filesystem>
#include <memory>

#include "paintlab/core/clock.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"
#include "paintlab/devices/filter_wheel.h"
#include "paintlab/devices/light.h"
#include "paintlab/devices/turntable.h"

namespace paintlab::sim {
class SimRig;
}

namespace paintlab::app {

struct RigDevices {
  // Declared first so it is destroyed last: the drivers disconnect before the peers stop.
  std::unique_ptr<sim::SimRig> sim;  // the simulated peers and world (when a kind is "sim")
  std::unique_ptr<dev::Turntable> turntable;
  std::unique_ptr<dev::Light> light;
  std::unique_ptr<dev::Camera> camera;
  std::unique_ptr<dev::FilterWheel> filter_wheel;  // when rig.toml has [devices.filter_wheel]
  // The clock every driver waits on: the world's virtual clock when all devices are
  // simulated, else the wall clock. Never null after open_rig_devices.
  Clock* clock = nullptr;

  RigDevices();
  RigDevices(RigDevices&&) noexcept;
  RigDevices& operator=(RigDevices&&) noexcept;
  ~RigDevices();
};

struct OpenDevicesOptions {
  bool turntable = true;
  bool light = true;
  bool camera = true;
  bool filter_wheel = true;
};

// Reads a rig.toml and checks all of it, the same for every command: the keys RigConfig
// owns, the kind-specific keys of [devices.*] and, when present, the simulator's [sim] table
// (even if no device is simulated: a file that `rig validate` passes works with `sim render`).
// Throws ConfigError naming file, line and key.
RigConfig load_rig(const std::filesystem::path& file);

// Opens the rig's devices. Throws ConfigError for bad device sections and DeviceError when a
// device cannot be opened (the message names the device).
RigDevices open_rig_devices(const RigConfig& rig, const OpenDevicesOptions& options = {});

}  // namespace paintlab::app
