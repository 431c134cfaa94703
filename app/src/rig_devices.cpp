#include "rig_devices.h"

#include "paintlab/core/error.h"
#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/devices/gpiod_light.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/devices/serial_filter_wheel.h"
#include "paintlab/sim/peers/sim_light.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/peers/sim_rig.h"

namespace paintlab::app {

RigDevices::RigDevices() = default;
RigDevices::RigDevices(RigDevices&&) noexcept = default;
RigDevices& RigDevices::operator=(RigDevices&&) noexcept = default;
RigDevices::~RigDevices() {
  filter_wheel.reset();
  camera.reset();
  light.reset();
  turntable.reset();
  sim.reset();
}

RigConfig load_rig(const std::filesystem::path& file) {
  RigConfig rig = RigConfig::load(file);
  dev::validate_device_sections(rig);
  if (rig.sim) (void)sim::SimConfig::from_rig(rig);
  return rig;
}

RigDevices open_rig_devices(const RigConfig& rig, const OpenDevicesOptions& options) {
  // Check every section before anything starts.
  dev::validate_device_sections(rig);
  RigDevices d;
  const bool sim_table = options.turntable && rig.turntable.kind == "sim";
  const bool sim_light = options.light && rig.light.kind == "sim";
  const bool sim_camera = options.camera && rig.camera.kind == "sim";
  const bool wheel = options.filter_wheel && rig.filter_wheel;
  const bool sim_wheel = wheel && rig.filter_wheel->kind == "sim";
  const bool all_sim = (!options.turntable || rig.turntable.kind == "sim") &&
                       (!options.light || rig.light.kind == "sim") && (!options.camera || rig.camera.kind == "sim") &&
                       (!wheel || sim_wheel);
  if (sim_table || sim_light || sim_camera || sim_wheel) {
    sim::SimRigOptions so;
    so.turntable = sim_table;
    if (sim_table) {
      bool rtu = dev::turntable_config(rig.turntable).transport == dev::ModbusTurntableConfig::Transport::Rtu;
      so.modbus_rtu = rtu;
      so.modbus_tcp = !rtu;
    }
    so.light = sim_light;
    so.camera = sim_camera;
    so.filter_wheel = sim_wheel;
    // A mix of real and simulated devices runs on the wall clock.
    so.clock = all_sim ? nullptr : &system_clock();
    d.sim = std::make_unique<sim::SimRig>(rig, so);
    d.clock = &d.sim->clock();
  } else {
    d.clock = &system_clock();
  }

  if (options.turntable) {
    dev::ModbusTurntableConfig tc = dev::turntable_config(rig.turntable);
    if (rig.turntable.kind == "sim") {
      if (tc.transport == dev::ModbusTurntableConfig::Transport::Tcp) {
        tc.host = "127.0.0.1";
        tc.port = d.sim->modbus_port();
      } else {
        tc.serial_device = d.sim->modbus_rtu_path();
      }
    }
    auto table = std::make_unique<dev::ModbusTurntable>(tc, *d.clock);
    if (auto r = table->connect(); !r) throw r.error();
    d.turntable = std::move(table);
  }
  if (options.light) {
    if (rig.light.kind == "sim")
      d.light = std::make_unique<sim::SimLightHandle>(*d.sim->light());
    else
      d.light = std::make_unique<dev::GpiodLight>(dev::gpiod_config(rig.light));
  }
  if (options.camera) {
    dev::AravisCameraConfig cc = dev::camera_config(rig.camera, rig.geometry);
    // The simulated sensor's readout time unless the rig gives one.
    if (rig.camera.kind == "sim" && cc.readout_s == 0.0) cc.readout_s = d.sim->world().config().sensor.readout_s;
    auto cam = dev::AravisCamera::open(cc);
    if (!cam) throw cam.error();
    d.camera = std::move(*cam);
  }
  if (wheel) {
    dev::SerialFilterWheelConfig wc = dev::filter_wheel_config(*rig.filter_wheel).serial;
    if (sim_wheel) wc.port = d.sim->filter_wheel()->port();
    d.filter_wheel = std::make_unique<dev::SerialFilterWheel>(wc, *d.clock);
  }
  return d;
}

}  // namespace paintlab::app
