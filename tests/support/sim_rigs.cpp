#include "sim_rigs.h"

#include <fmt/format.h>

namespace paintlab::test {

std::string small_sim_rig(int positions, double step_deg, int exposures, int width, int height,
                          const std::string& extra) {
  // Sphere image radius ~ f / pixel * r / d: 0.25 * height.
  const double distance_m = 1.2, radius_m = 0.04, pixel_um = 6.45;
  const double focal_mm = 0.25 * height * distance_m / radius_m * pixel_um * 1e-3;
  return fmt::format(R"(name = "test-sim-rig"
calibration = "calib"

[devices.turntable]
kind = "sim"
register_map = "oriental-az"

[devices.light]
kind = "sim"

[devices.camera]
kind = "sim"
pixel_format = "Mono16"

[geometry]
sphere_radius_m = {radius}
arm_radius_m = 0.6
arm_height_m = 0.0
camera_distance_m = {distance}
camera_height_m = 0.05
focal_length_mm = {focal:.4f}
pixel_size_um = {pixel}
image_width_px = {w}
image_height_px = {h}

[plan]
angle_start_deg = 0
angle_stop_deg = {stop}
angle_step_deg = {step}
settle_s = 0.2
dark_frames = 2
[plan.bracket]
min_ms = 0.5
max_ms = 200
count = {n}
{extra}
)",
                     fmt::arg("radius", radius_m), fmt::arg("distance", distance_m), fmt::arg("focal", focal_mm),
                     fmt::arg("pixel", pixel_um), fmt::arg("w", width), fmt::arg("h", height),
                     fmt::arg("stop", (positions - 1) * step_deg), fmt::arg("step", step_deg), fmt::arg("n", exposures),
                     fmt::arg("extra", extra));
}

}  // namespace paintlab::test
