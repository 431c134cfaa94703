#pragma once
// Small simulated rigs for tests: the real drivers against the sim peers, with images
// small enough that a sweep takes seconds.
#include <string>

namespace paintlab::test {

// A rig.toml text: all devices simulated, a `width` x `height` camera with a short lens so
// the sphere fills about half the frame height, `positions` light angles from 0 in
// `step_deg` steps and `exposures` exposures from 0.5 ms to 200 ms. `extra` is appended
// (e.g. a [sim] table).
std::string small_sim_rig(int positions = 5, double step_deg = 10.0, int exposures = 4, int width = 320,
                          int height = 240, const std::string& extra = "");

}  // namespace paintlab::test
