#pragma once
// `paintlab check`: is the rig fit to measure? Every check compares one figure with its
// tolerance from rig.toml ([tolerances], core/rig.h) and says what to do when it fails.
//
// Three groups:
// - the calibration files: present, not older than calibration_max_age_days, made with the
//   same devices (serials in each file's provenance; against the connected devices when
//   known);
// - the figures the calibrations recorded (reprojection RMS, views, response linearity,
//   hot pixels, dark level, flat-field falloff, silhouette fit, edge width, LED circle
//   residual, scale uncertainty, saturated reference);
// - live evidence taken now (LiveEvidence): the sphere where sphere.json says it is, a sharp
//   silhouette, highlights where light.json puts the LED, a steady LED, an unsaturated
//   reference. Each live check runs only when its evidence is given.
// Written as calib/check.json.
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/calibration/light.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::calib {

enum class Limit { AtMost, AtLeast, Required };

struct CheckItem {
  std::string id;       // "intrinsics.rms_px", "sphere.shift_mm", ...
  std::string what;     // one line for people
  Limit limit = Limit::AtMost;
  double value = std::numeric_limits<double>::quiet_NaN();
  double tolerance = std::numeric_limits<double>::quiet_NaN();
  std::string unit;
  bool pass = false;
  std::string detail;   // what was measured, or why the check could not run
  std::string action;   // what to do when it fails
};

struct CheckReport {
  std::string rig;
  std::string date;
  std::vector<CheckItem> items;

  bool passed() const;
  int failures() const;
  const CheckItem* find(const std::string& id) const;
  // A fixed-width table: check, value, tolerance, verdict, and what to do for failures.
  std::string table() const;
  Json to_json() const;
  void save(const std::filesystem::path& path) const;  // atomic
};

// Evidence taken now, for the live checks.
struct LiveEvidence {
  std::optional<SphereFit> sphere;       // the sample sphere fitted now (sphere shift, edge width)
  std::vector<Highlight> highlights;     // highlights found now on a glossy sphere
  std::optional<double> drift_rel;       // LED intensity change over the check (intensity_drift_rel)
  std::optional<double> reference_saturated_frac;  // of a reference image taken now
  Json devices = Json::object();         // serials of the connected devices ({"camera": ...}); empty: unknown
};

CheckReport run_checks(const RigConfig& rig, const RigCalibration& cal, const LiveEvidence& live = {});

// Largest relative change of the mean value on the sphere between the first image and
// each later one (repeated images at one table angle and exposure: an LED that drifts).
double intensity_drift_rel(const std::vector<ImageF>& repeated, const CameraModel& camera, const SphereFit& sphere);

}  // namespace paintlab::calib
