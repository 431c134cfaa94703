#pragma once
// Simulated rigs for tests: the real drivers against the sim peers, with images small
// enough that a sweep takes seconds. One writer of rig.toml text for every test.
#include <optional>
#include <string>

namespace paintlab::test {

struct SimRigSpec {
  std::string name = "test-sim-rig";
  std::string calibration = "calib";     // relative to the rig file, or absolute
  std::string turntable_extra;           // lines added to [devices.turntable]
  std::string pixel_format = "Mono16";
  int width = 320;
  int height = 240;
  // Default: a short lens so the sphere fills about half the frame height.
  std::optional<double> focal_length_mm;
  double camera_height_m = 0.05;
  int positions = 5;                     // light angles from 0 in step_deg steps
  double step_deg = 10.0;
  double settle_s = 0.2;
  std::optional<int> dark_frames = 2;    // nullopt: rig.toml's default
  int exposures = 4;                     // a geometric bracket from 0.5 ms to 200 ms, or:
  std::string exposures_ms;              // an explicit list ("[1, 10, 100]") instead
  std::string extra;                     // appended (e.g. a [sim] table)
};

// The rig.toml text of `spec`: every device simulated.
std::string sim_rig_toml(const SimRigSpec& spec);

// sim_rig_toml with the defaults but these.
std::string small_sim_rig(int positions = 5, double step_deg = 10.0, int exposures = 4, int width = 320,
                          int height = 240, const std::string& extra = "");

}  // namespace paintlab::test
