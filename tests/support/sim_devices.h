#pragma once
// The devices of an all-simulated rig for tests that need the real drivers against the
// simulated peers but not the command line: the ModbusTurntable driver over Modbus TCP on
// 127.0.0.1, the AravisCamera driver over GigE Vision on 127.0.0.1 and the simulated LED,
// all on the world's virtual clock. (app/'s device factory does this for every device kind;
// tests of acquisition and calibration must not link app code.)
#include <memory>

#include "paintlab/acquisition/runner.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"
#include "paintlab/devices/light.h"
#include "paintlab/devices/turntable.h"
#include "paintlab/sim/peers/sim_rig.h"

namespace paintlab::test {

struct SimDevices {
  std::unique_ptr<sim::SimRig> sim;  // first, so it is destroyed last
  std::unique_ptr<dev::Turntable> turntable;
  std::unique_ptr<dev::Light> light;
  std::unique_ptr<dev::Camera> camera;

  SimDevices() = default;
  SimDevices(SimDevices&&) noexcept = default;
  SimDevices& operator=(SimDevices&&) noexcept;
  ~SimDevices();
  Clock& clock() { return sim->clock(); }
  acq::RigHandles handles() { return {*turntable, *light, *camera, sim->clock()}; }
};

// Starts the peers of `rig` (every device of kind "sim", turntable over Modbus TCP) and
// connects the drivers. Throws what the drivers throw.
SimDevices open_sim_devices(const RigConfig& rig);

}  // namespace paintlab::test
