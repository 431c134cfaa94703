#include "paintlab/calibration/rig_calibration.h"

#include <cmath>
#include <limits>

#include "paintlab/calibration/procedure.h"
#include "paintlab/core/error.h"

namespace paintlab::calib {

const std::vector<std::string>& standard_files() {
  static const std::vector<std::string> files = [] {
    std::vector<std::string> f;
    for (const ProcedureStep& s : calibration_procedure()) f.push_back(s.file);
    return f;
  }();
  return files;
}

std::string calibrate_step_for(const std::string& file) {
  for (const ProcedureStep& s : calibration_procedure())
    if (s.file == file) return s.name;
  return "all";
}

RigCalibration RigCalibration::load(const std::filesystem::path& dir) {
  RigCalibration c;
  c.dir_ = dir;
  for (const std::string& name : standard_files()) {
    CalibrationFile f;
    f.name = name;
    f.path = dir / name;
    f.present = std::filesystem::exists(f.path);
    if (f.present) {
      f.json = read_json_file(f.path);
      if (f.json.contains("provenance")) f.provenance = Provenance::from_json(f.json.at("provenance"), f.path.string());
      const std::string where = f.path.string();
      if (f.name == kCameraFile) c.intrinsics_ = IntrinsicsResult::from_json(f.json, where);
      if (f.name == kDarkFile) c.dark_ = DarkFrame::load(f.path);
      if (f.name == kResponseFile) c.response_ = ResponseCurve::from_json(f.json, where);
      if (f.name == kFlatFile) c.flat_ = FlatField::load(f.path);
      if (f.name == kSphereFile) c.sphere_ = SphereFit::from_json(f.json, where);
      if (f.name == kLightFile) c.light_ = LightCalibration::from_json(f.json, where);
      if (f.name == kScaleFile) c.scale_ = ScaleCalibration::from_json(f.json, where);
    }
    c.files_[name] = std::move(f);
  }
  if (std::filesystem::exists(dir / kColourFile)) {
    c.colour_ = ColourCalibration::load(dir / kColourFile);
    c.colour_provenance_ = c.colour_->provenance;
  }
  return c;
}

bool RigCalibration::has(const std::string& file) const {
  auto it = files_.find(file);
  return it != files_.end() && it->second.present;
}

void RigCalibration::require(std::initializer_list<const char*> files) const {
  std::string missing;
  for (const char* f : files)
    if (!has(f)) missing += "\n  " + (dir_ / f).string() + ": run `paintlab calibrate " + calibrate_step_for(f) + " --rig RIG`";
  if (!missing.empty()) throw CalibrationError("the rig's calibration is incomplete:" + missing);
}

const CameraModel& RigCalibration::camera() const {
  if (!intrinsics_) require({kCameraFile});
  return intrinsics_->camera;
}

std::optional<SurfacePoint> RigCalibration::sphere_point(const Vec3& ray) const {
  if (!sphere_) require({kSphereFile});
  auto X = intersect_sphere(ray, sphere_->centre_cam_m, sphere_->radius_m);
  if (!X) return std::nullopt;
  SurfacePoint p;
  p.point = *X;
  p.normal = (*X - sphere_->centre_cam_m) / sphere_->radius_m;
  p.to_camera = (-*X).normalized();
  return p;
}

LightModel RigCalibration::light_model() const {
  if (!light_) require({kLightFile});
  LightModel m = light_->model;
  if (scale_) m.profile_exponent = scale_->profile_exponent;
  return m;
}

double RigCalibration::irradiance(double table_angle_deg, const SurfacePoint& p) const {
  return light_model().irradiance(table_angle_deg, p.point, p.normal);
}

double RigCalibration::brdf(double rate_dn_per_s, double table_angle_deg, const SurfacePoint& p) const {
  if (!scale_) require({kScaleFile});
  const double E = irradiance(table_angle_deg, p);
  if (!(E > 0)) return std::numeric_limits<double>::quiet_NaN();
  return scale_->brdf(rate_dn_per_s, E);
}

}  // namespace paintlab::calib
