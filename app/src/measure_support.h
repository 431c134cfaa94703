#pragma once
// What `paintlab measure` (and the demo) add to acquisition/measurement.h: the simulated
// paint on a sim rig.
#include <filesystem>
#include <string>

#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/core/json.h"
#include "rig_devices.h"

namespace paintlab::app {

// Puts the session's simulated paint (brdf::to_json, session.json's options.sim_paint) on the sphere.
void apply_sim_paint(RigDevices& devices, const Json& paint_json, const std::filesystem::path& where);

}  // namespace paintlab::app
