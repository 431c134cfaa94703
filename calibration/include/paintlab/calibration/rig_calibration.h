#pragma once
// Everything the rig's calibration folder holds, loaded once for acquisition and fitting,
// with the geometry fitting needs: pixel -> ray, ray -> sphere point and normal, the LED
// position at a table angle, the irradiance at a sphere point, pixel value -> BRDF.
//
//   RigCalibration cal = RigCalibration::load(rig);            // what exists
//   cal.require({kCameraFile, kSphereFile, kLightFile, kScaleFile});  // or a CalibrationError
//   auto sp = cal.sphere_point_at(Vec2(700, 500));            // point, normal, view direction
//   double E = cal.irradiance(30.0, *sp);                     // per unit LED intensity, 1/m^2
//   double f = cal.brdf(rate_dn_per_s, 30.0, *sp);            // 1/sr
//
// Every file is loaded as its own type (camera, dark, response, flat, sphere, light, scale);
// the dark and flat maps (their .exr beside the JSON) with them, checked against the
// SHA-256 their JSON records.
#include <filesystem>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::calib {

// A point of the sample sphere seen by the camera (camera frame).
struct SurfacePoint {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  Vec3 to_camera = Vec3::UnitZ();  // unit wo
};

// One file of the calibration folder as found on disk.
struct CalibrationFile {
  std::string name;                 // "camera.json", ...
  std::filesystem::path path;
  bool present = false;
  Json json;                        // the parsed file (when present)
  std::optional<Provenance> provenance;
};

class RigCalibration {
 public:
  // Loads every standard file that exists in `dir` (record.h names). A file that exists
  // but cannot be read or parsed throws DataError/IoError naming it.
  static RigCalibration load(const std::filesystem::path& dir);
  static RigCalibration load(const RigConfig& rig) { return load(rig.calibration_dir); }

  const std::filesystem::path& dir() const { return dir_; }
  // The standard files in a fixed order, present or not.
  const std::map<std::string, CalibrationFile>& files() const { return files_; }
  bool has(const std::string& file) const;
  std::filesystem::path path(const std::string& file) const { return dir_ / file; }
  // Throws CalibrationError naming every missing file and the command that makes it.
  void require(std::initializer_list<const char*> files) const;

  const std::optional<IntrinsicsResult>& intrinsics() const { return intrinsics_; }
  const std::optional<DarkFrame>& dark() const { return dark_; }
  const std::optional<ResponseCurve>& response() const { return response_; }
  const std::optional<FlatField>& flat() const { return flat_; }
  const std::optional<SphereFit>& sphere() const { return sphere_; }
  const std::optional<LightCalibration>& light() const { return light_; }
  const std::optional<ScaleCalibration>& scale() const { return scale_; }
  // colour.json (`paintlab calibrate colour`): optional, a colour camera's; not a step of
  // `calibrate all` yet, so not among files().
  const std::optional<ColourCalibration>& colour() const { return colour_; }
  const std::optional<Provenance>& colour_provenance() const { return colour_provenance_; }

  // --- geometry (each throws CalibrationError naming the missing file) ---
  const CameraModel& camera() const;
  Vec3 pixel_ray(const Vec2& px) const { return camera().ray(px); }
  std::optional<SurfacePoint> sphere_point(const Vec3& ray) const;
  std::optional<SurfacePoint> sphere_point_at(const Vec2& px) const { return sphere_point(pixel_ray(px)); }
  // The light model with the emission profile of scale.json (when present).
  LightModel light_model() const;
  Vec3 led_position_cam(double table_angle_deg) const { return light_model().led_position_cam(table_angle_deg); }
  Rigid3 cam_from_rig() const { return light_model().cam_from_rig(); }
  // Irradiance per unit LED intensity (1/m^2) at a sphere point; 0 when unlit.
  double irradiance(double table_angle_deg, const SurfacePoint& p) const;
  // BRDF (1/sr) of a linear pixel value per second at a sphere point; NaN when unlit.
  double brdf(double rate_dn_per_s, double table_angle_deg, const SurfacePoint& p) const;

 private:
  std::filesystem::path dir_;
  std::map<std::string, CalibrationFile> files_;
  std::optional<IntrinsicsResult> intrinsics_;
  std::optional<DarkFrame> dark_;
  std::optional<ResponseCurve> response_;
  std::optional<FlatField> flat_;
  std::optional<SphereFit> sphere_;
  std::optional<ColourCalibration> colour_;
  std::optional<Provenance> colour_provenance_;
  std::optional<LightCalibration> light_;
  std::optional<ScaleCalibration> scale_;
};

// The standard files in the order of the calibration procedure (procedure.h): camera, dark,
// response, flat, sphere, light, scale.
const std::vector<std::string>& standard_files();

// The `paintlab calibrate` step that writes a standard file ("intrinsics" for camera.json).
std::string calibrate_step_for(const std::string& file);

}  // namespace paintlab::calib
