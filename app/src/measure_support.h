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

// The paint of a simulated sphere as JSON (brdf::to_json): from a paint file, or the
// built-in silver metallic when `paint_file` is empty.
Json load_sim_paint_json(const std::string& paint_file);
void apply_sim_paint(RigDevices& devices, const Json& paint_json, const std::filesystem::path& where);

}  // namespace paintlab::app
