#include "paintlab/calibration/score.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"

namespace paintlab::calib {

namespace {

double score_angle_deg(const Vec3& u, const Vec3& v) {
  return std::acos(std::clamp(u.dot(v), -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

// Linear interpolation in the sampled inverse response (ascending in raw value).
double score_interpolate(const std::vector<std::pair<double, double>>& f, double x) {
  auto hi = std::lower_bound(f.begin(), f.end(), x, [](const auto& p, double v) { return p.first < v; });
  if (hi == f.begin()) return f.front().second;
  if (hi == f.end()) return f.back().second;
  const auto lo = std::prev(hi);
  const double t = (x - lo->first) / (hi->first - lo->first);
  return lo->second + t * (hi->second - lo->second);
}

}  // namespace

Json CalibrationScore::to_json() const {
  Json j = Json::object();
  const auto put = [&](const char* key, const std::optional<double>& v) {
    if (v) j[key] = *v;
  };
  put("reprojection_rms_px", reprojection_rms_px);
  put("focal_error_rel", focal_error_rel);
  put("principal_point_error_px", principal_point_error_px);
  put("principal_point_std_px", principal_point_std_px);
  put("sphere_centre_error_mm", sphere_centre_error_mm);
  put("light_angle_error_deg", light_angle_error_deg);
  put("light_direction_error_deg", light_direction_error_deg);
  put("sphere_distance_error_mm", sphere_distance_error_mm);
  put("response_error_rel", response_error_rel);
  return j;
}

CalibrationScore score_calibration(const RigCalibration& cal, const CalibrationTruth& truth) {
  if (truth.angles_deg.size() != truth.led_cam_m.size())
    throw DataError("calibration truth: " + std::to_string(truth.led_cam_m.size()) + " LED positions for " +
                    std::to_string(truth.angles_deg.size()) + " angles");
  CalibrationScore s;
  const Mat3& K = truth.K;
  if (cal.intrinsics()) {
    const CameraModel& cam = cal.intrinsics()->camera;
    s.reprojection_rms_px = cal.intrinsics()->rms_px;
    s.focal_error_rel = (cam.fx() - K(0, 0)) / K(0, 0);
    s.principal_point_error_px = std::hypot(cam.cx() - K(0, 2), cam.cy() - K(1, 2));
    const IntrinsicsStd& sd = cal.intrinsics()->std;
    if (sd.cx > 0 || sd.cy > 0) s.principal_point_std_px = std::hypot(sd.cx, sd.cy);  // 0: camera.json has none
  }
  const Vec3& c_true = truth.sphere_centre_cam_m;
  if (cal.sphere()) s.sphere_centre_error_mm = (cal.sphere()->centre_cam_m - c_true).norm() * 1e3;
  if (cal.light() && cal.sphere() && !truth.angles_deg.empty()) {
    double worst = 0, worst_dir = 0;
    const Vec3 c_cal = cal.sphere()->centre_cam_m;
    for (std::size_t i = 0; i < truth.angles_deg.size(); ++i) {
      const Vec3 l_cal = (cal.led_position_cam(truth.angles_deg[i]) - c_cal).normalized();
      const Vec3 l_true = (truth.led_cam_m[i] - c_true).normalized();
      const double phase_cal = score_angle_deg(l_cal, (-c_cal).normalized());
      const double phase_true = score_angle_deg(l_true, (-c_true).normalized());
      worst = std::max(worst, std::abs(phase_cal - phase_true));
      worst_dir = std::max(worst_dir, score_angle_deg(l_cal, l_true));
    }
    s.light_angle_error_deg = worst;
    s.light_direction_error_deg = worst_dir;
    s.sphere_distance_error_mm = (c_cal.norm() - c_true.norm()) * 1e3;
  }
  if (cal.response() && truth.inverse_response.size() >= 2) {
    const ResponseCurve& g = *cal.response();
    const double shift = std::ldexp(1.0, g.bit_depth - truth.adc_bits);
    const double span = (truth.adc_max_dn - truth.black_level_dn) * shift;
    const double lo = std::max(g.window.floor_dn, 0.02 * span), hi = g.window.u_saturation();
    double sgt = 0, sgg = 0;
    std::vector<std::pair<double, double>> pts;
    for (int i = 0; i <= 200; ++i) {
      const double u = lo + (hi - lo) * i / 200.0;
      const double gv = g.to_linear(0, u), tv = score_interpolate(truth.inverse_response, u / span) * span;
      pts.emplace_back(gv, tv);
      sgt += gv / tv;
      sgg += gv * gv / (tv * tv);
    }
    const double k = sgt / sgg;
    double worst = 0;
    for (auto [gv, tv] : pts) worst = std::max(worst, std::abs(k * gv / tv - 1.0));
    s.response_error_rel = worst;
  }
  return s;
}

}  // namespace paintlab::calib
