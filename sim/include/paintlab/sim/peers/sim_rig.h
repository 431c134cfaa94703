#pragma once
// The simulated rig as the drivers see it: a SimWorld and the peers that serve it over the
// real protocols (the Modbus controller on 127.0.0.1 TCP and/or a pty, the GigE Vision
// camera on 127.0.0.1, SimLight, a filter wheel on a pty pair). The camera's frames are
// rendered by the world for the requested exposure and gain at the table angle the Modbus
// controller has reached, with the LED as SimLight has switched it and, for a monochrome
// camera behind the wheel, through the filter in front of the lens (w . (T x scene RGB)). Used by `paintlab sim serve` and by app's device
// factory for rigs whose devices are of kind "sim".
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "paintlab/core/clock.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/peers/gige_camera.h"
#include "paintlab/sim/peers/sim_filter_wheel.h"
#include "paintlab/sim/peers/sim_light.h"
#include "paintlab/sim/peers/turntable_server.h"
#include "paintlab/sim/world.h"

namespace paintlab::sim {

struct SimRigOptions {
  bool turntable = true;    // serve the Modbus controller
  bool modbus_tcp = true;   // on 127.0.0.1:modbus_port
  int modbus_port = 0;      // 0: any free port
  bool modbus_rtu = false;  // on a socat pty pair
  bool camera = true;       // serve the GigE Vision camera (holds port 3956)
  bool light = true;
  bool filter_wheel = true;  // a [devices.filter_wheel] of kind "sim": the wheel on a pty pair
  // The clock the peers run on. nullptr: the world's virtual clock (in-process use, the
  // drivers must wait on the same clock); a separate process needs the wall clock.
  Clock* clock = nullptr;
};

class SimRig {
 public:
  // Builds the world from the rig ([geometry] and [sim]) and starts the peers the options
  // ask for. Throws ConfigError for bad device sections, DeviceError when a peer cannot start.
  SimRig(const RigConfig& rig, SimRigOptions options = {});
  ~SimRig();
  SimRig(const SimRig&) = delete;
  SimRig& operator=(const SimRig&) = delete;

  SimWorld& world() { return *world_; }
  Clock& clock() { return *clock_; }
  TurntableServer* turntable() { return turntable_.get(); }
  GigeCamera* camera() { return camera_.get(); }
  SimLight* light() { return light_.get(); }
  SimFilterWheel* filter_wheel() { return wheel_.get(); }
  int modbus_port() const { return modbus_port_; }
  const std::string& modbus_rtu_path() const { return rtu_path_; }

  // The frame source that renders the world (exposed for tests).
  FrameSource world_source();
  // Frames of a fixed scene radiance (a board, a dark or uniform field) through the
  // simulated sensor, exposed as world_source() exposes the world.
  FrameSource static_source(std::shared_ptr<const ImageF> radiance);
  // The camera shows `radiance` (a calibration target in front of the lens) until
  // show_world() puts the sphere back in view.
  void show(std::shared_ptr<const ImageF> radiance);
  void show_world();

 private:
  std::unique_ptr<SimWorld> world_;
  Clock* clock_ = nullptr;
  std::unique_ptr<TurntableServer> turntable_;
  std::unique_ptr<SimLight> light_;
  std::unique_ptr<SimFilterWheel> wheel_;
  std::vector<std::array<double, 3>> wheel_mix_;  // per slot (index slot - 1): mono_weights x the filter's transmission
  std::unique_ptr<GigeCamera> camera_;
  int modbus_port_ = 0;
  std::string rtu_path_;
  struct Cache;
  std::shared_ptr<Cache> cache_;
};

}  // namespace paintlab::sim
