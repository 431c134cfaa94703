#include "sim_devices.h"

#include <stdexcept>

#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/sim/peers/sim_light.h"
#include "paintlab/sim/world.h"

namespace paintlab::test {


SimDevices& SimDevices::operator=(SimDevices&& o) noexcept {
  camera.reset();
  light.reset();
  turntable.reset();
  sim.reset();
  sim = std::move(o.sim);
  turntable = std::move(o.turntable);
  light = std::move(o.light);
  camera = std::move(o.camera);
  return *this;
}

SimDevices::~SimDevices() {
  camera.reset();  // the drivers disconnect before the peers stop
  light.reset();
  turntable.reset();
  sim.reset();
}

SimDevices open_sim_devices(const RigConfig& rig) {
  if (rig.turntable.kind != "sim" || rig.light.kind != "sim" || rig.camera.kind != "sim")
    throw std::invalid_argument("open_sim_devices: every device of the rig must be of kind \"sim\"");
  dev::validate_device_sections(rig);
  SimDevices d;
  sim::SimRigOptions so;
  so.turntable = so.light = so.camera = true;
  so.modbus_tcp = true;
  so.modbus_rtu = false;
  d.sim = std::make_unique<sim::SimRig>(rig, so);

  dev::ModbusTurntableConfig tc = dev::turntable_config(rig.turntable);
  tc.transport = dev::ModbusTurntableConfig::Transport::Tcp;
  tc.host = "127.0.0.1";
  tc.port = d.sim->modbus_port();
  auto table = std::make_unique<dev::ModbusTurntable>(tc, d.sim->clock());
  if (auto r = table->connect(); !r) throw r.error();
  d.turntable = std::move(table);
  d.light = std::make_unique<sim::SimLightHandle>(*d.sim->light());
  dev::AravisCameraConfig cc = dev::camera_config(rig.camera, rig.geometry);
  if (cc.readout_s == 0.0) cc.readout_s = d.sim->world().config().sensor.readout_s;
  auto cam = dev::AravisCamera::open(cc);
  if (!cam) throw cam.error();
  d.camera = std::move(*cam);
  return d;
}

}  // namespace paintlab::test
