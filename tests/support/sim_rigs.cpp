#include "sim_rigs.h"

#include <fmt/format.h>

namespace paintlab::test {

std::string sim_rig_toml(const SimRigSpec& s) {
  // Sphere image radius ~ f / pixel * r / d: 0.25 * height.
  const double distance_m = 1.2, radius_m = 0.04, pixel_um = 6.45;
  const double focal_mm = s.focal_length_mm.value_or(0.25 * s.height * distance_m / radius_m * pixel_um * 1e-3);
  const std::string exposures =
      s.exposures_ms.empty() ? fmt::format("[plan.bracket]\nmin_ms = 0.5\nmax_ms = 200\ncount = {}\n", s.exposures)
                             : "exposures_ms = " + s.exposures_ms + "\n";
  const std::string dark = s.dark_frames ? fmt::format("dark_frames = {}\n", *s.dark_frames) : std::string();
  return fmt::format(R"(name = "{name}"
calibration = "{calib}"

[devices.turntable]
kind = "sim"
register_map = "oriental-az"
{turntable}
[devices.light]
kind = "sim"

[devices.camera]
kind = "sim"
pixel_format = "{format}"

[geometry]
sphere_radius_m = {radius}
arm_radius_m = 0.6
arm_height_m = 0.0
camera_distance_m = {distance}
camera_height_m = {camera_height}
focal_length_mm = {focal:.4f}
pixel_size_um = {pixel}
image_width_px = {w}
image_height_px = {h}

[plan]
angle_start_deg = 0
angle_stop_deg = {stop}
angle_step_deg = {step}
settle_s = {settle}
{dark}{exposures}
{extra}
)",
                     fmt::arg("name", s.name), fmt::arg("calib", s.calibration), fmt::arg("turntable", s.turntable_extra),
                     fmt::arg("format", s.pixel_format), fmt::arg("radius", radius_m), fmt::arg("distance", distance_m),
                     fmt::arg("camera_height", s.camera_height_m), fmt::arg("focal", focal_mm),
                     fmt::arg("pixel", pixel_um), fmt::arg("w", s.width), fmt::arg("h", s.height),
                     fmt::arg("stop", (s.positions - 1) * s.step_deg), fmt::arg("step", s.step_deg),
                     fmt::arg("settle", s.settle_s), fmt::arg("dark", dark), fmt::arg("exposures", exposures),
                     fmt::arg("extra", s.extra));
}

std::string small_sim_rig(int positions, double step_deg, int exposures, int width, int height,
                          const std::string& extra) {
  SimRigSpec s;
  s.positions = positions;
  s.step_deg = step_deg;
  s.exposures = exposures;
  s.width = width;
  s.height = height;
  s.extra = extra;
  return sim_rig_toml(s);
}

}  // namespace paintlab::test
