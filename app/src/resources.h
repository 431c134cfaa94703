#pragma once
// Files built into the paintlab binary so `paintlab demo` runs from anywhere: the
// simulated rig (examples/rig-sim.toml) and the shipped paints (paints/*.toml).
#include <string>
#include <vector>

namespace paintlab::app::resources {

const char* rig_sim_toml();
const char* paint_silver_metallic_toml();
const char* paint_solid_blue_toml();
const char* paint_pearlescent_toml();

// (file name, text) of every built-in paint.
inline std::vector<std::pair<std::string, const char*>> builtin_paints() {
  return {{"silver-metallic.toml", paint_silver_metallic_toml()},
          {"solid-blue.toml", paint_solid_blue_toml()},
          {"pearlescent.toml", paint_pearlescent_toml()}};
}

}  // namespace paintlab::app::resources
