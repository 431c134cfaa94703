#pragma once
// rig.toml: the description of one measurement rig (DESIGN.md): its devices, geometry,
// measurement plan and check tolerances. RigConfig::load validates every key it owns
// (unknown keys, types, ranges; errors name file, line and key). Device sections are
// kept as tables whose keys the devices module validates for the chosen `kind`; the
// optional [sim] table belongs to the simulator.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/core/config.h"
#include "paintlab/core/json.h"

namespace paintlab {

// One device of the rig: its kind ("modbus-tcp", "modbus-rtu", "gpiod", "aravis", "sim")
// and its table (devices.<role>) for the driver to read.
struct DeviceSection {
  std::string role;  // "turntable", "light", "camera", "filter_wheel"
  std::string kind;
  std::optional<ConfigTable> table;
};

// Nominal geometry (the guesses that calibration refines). Rig frame: origin at the sphere
// centre, z up; the camera looks at the sphere from azimuth 0 (the +x axis).
struct RigGeometry {
  double sphere_radius_m = 0.04;      // measured with a caliper
  double arm_radius_m = 0.5;          // LED distance from the table axis
  double arm_height_m = 0.0;          // LED height above the sphere centre
  double arm_zero_deg = 0.0;          // LED azimuth when the table reads 0 deg
  double camera_distance_m = 1.0;     // camera centre to sphere centre
  double camera_height_m = 0.0;       // camera centre above the sphere centre
  double focal_length_mm = 50.0;      // lens focal length (guess)
  double pixel_size_um = 6.45;        // sensor pixel pitch
  int image_width_px = 1360;
  int image_height_px = 1024;
};

// What rig.toml's [plan] may ask for (RigConfig::load refuses more, saying why): the
// turntable's resolution, the positions a session holds (36,001 is a 0.01 deg step over a
// full turn) and the capture time of one sweep.
inline constexpr double kMinAngleStepDeg = 0.001;
inline constexpr int kMaxPlanPositions = 36001;
inline constexpr double kMaxPlanHours = 72.0;

// The light sweep and the exposure bracket.
struct MeasurementPlan {
  double angle_start_deg = 0.0;
  double angle_stop_deg = 180.0;
  double angle_step_deg = 1.0;
  std::vector<double> exposures_s;   // the bracket, ascending
  double settle_s = 0.5;             // wait after a move before capturing
  int dark_frames = 4;               // dark frames per exposure at the start
  double gain_db = 0.0;

  // Angles start, start+step, ... up to stop (inclusive within 1e-9).
  std::vector<double> angles_deg() const;
};

// Tolerances of the checks (`paintlab check`). Each is the largest (or smallest)
// acceptable value of the quantity it names.
struct Tolerances {
  double reprojection_rms_px = 0.5;       // intrinsics: chessboard reprojection RMS
  int min_views = 8;                      // intrinsics: views kept after outliers
  double response_error_rel = 0.02;       // response: linearity after linearisation
  double hot_pixel_frac = 0.001;          // dark: hot pixels allowed (fraction)
  double dark_level_frac = 0.05;          // dark: mean dark level / full scale
  double flat_min_ratio = 0.5;            // flat: darkest / brightest corner allowed
  double sphere_shift_mm = 0.5;           // sphere: centre moved since calibration
  double sphere_fit_rms_px = 0.3;         // sphere: silhouette ellipse fit residual
  double edge_width_px = 2.0;             // sphere: silhouette edge width (focus)
  double light_angle_deg = 0.2;           // light: highlight residual per angle
  double light_drift_rel = 0.02;          // light: LED intensity change over the check
  double scale_error_rel = 0.02;          // scale: uncertainty of the absolute scale
  double saturated_frac = 0.0;            // scale: saturated reference pixels allowed
  double calibration_max_age_days = 30.0; // any: older calibrations are stale
  double colour_mean_de00 = 1.0;          // colour: mean CIEDE2000 over the chart's patches
  double colour_max_de00 = 3.0;           // colour: the worst patch's CIEDE2000
};

struct RigConfig {
  std::filesystem::path file;              // the rig.toml it came from (absolute)
  std::string name;
  std::filesystem::path calibration_dir;   // absolute; `calibration` relative to file
  DeviceSection turntable;
  DeviceSection light;
  DeviceSection camera;
  std::optional<DeviceSection> filter_wheel;  // [devices.filter_wheel]: a mono camera's colour filters
  RigGeometry geometry;
  MeasurementPlan plan;
  Tolerances tolerances;
  std::optional<ConfigTable> sim;          // [sim]: the simulated world's truth

  // Loads and validates. Throws ConfigError (file, line, key) or IoError.
  static RigConfig load(const std::filesystem::path& path);
  static RigConfig parse(const ConfigTable& root, const std::filesystem::path& file);
  // Whether every device (the filter wheel too, when there is one) is simulated.
  bool all_simulated() const;
  Json to_json() const;
  // What `paintlab rig validate` prints: "rig 'NAME' (FILE): valid", then one line each for
  // the calibration folder, the devices' kinds, the geometry (mm, deg, px), the light angles
  // and the exposure bracket (ms).
  std::string describe() const;
};

// Builds a geometric bracket of `count` exposures from min_s to max_s.
std::vector<double> geometric_bracket(double min_s, double max_s, int count);

}  // namespace paintlab
