#include "paintlab/calibration/light.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "paintlab/calibration/cost_functions.h"
#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "dense_solve.h"

namespace paintlab::calib {

void LightOptions::check() const {
  if (half_window_px < 0 || half_window_px > 200) throw UsageError("light: half_window_px must be in [0, 200]");
  if (!(min_snr > 0)) throw UsageError("light: min_snr must be > 0");
  if (!(max_view_angle_deg > 10 && max_view_angle_deg < 90)) throw UsageError("light: max_view_angle_deg must be in (10, 90)");
  if (outlier_deg < 0) throw UsageError("light: outlier_deg must be >= 0");
  if (min_limb_distance_px < 0) throw UsageError("light: min_limb_distance_px must be >= 0");
}

// ---- LightModel ----

Rigid3 LightModel::cam_from_rig() const {
  const Vec3 z = axis_cam.normalized();
  Vec3 to_cam = -origin_cam;
  Vec3 x = (to_cam - to_cam.dot(z) * z).normalized();
  Vec3 y = z.cross(x);
  Mat3 R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  Rigid3 t;
  t.rotation = Eigen::Quaterniond(R);
  t.translation = origin_cam;
  return t;
}

Vec3 LightModel::led_position_rig(double table_angle_deg) const {
  const double a = deg_to_rad(table_angle_deg + zero_deg);
  return {arm_radius_m * std::cos(a), arm_radius_m * std::sin(a), arm_height_m};
}

Vec3 LightModel::led_position_cam(double table_angle_deg) const { return cam_from_rig() * led_position_rig(table_angle_deg); }

Vec3 LightModel::led_axis_cam(double table_angle_deg) const {
  return (origin_cam - led_position_cam(table_angle_deg)).normalized();
}

double LightModel::led_profile(double table_angle_deg, const Vec3& point_cam) const {
  if (profile_exponent == 0.0) return 1.0;
  const Vec3 L = led_position_cam(table_angle_deg);
  const double c = led_axis_cam(table_angle_deg).dot((point_cam - L).normalized());
  return c > 0 ? std::pow(c, profile_exponent) : 0.0;
}

double LightModel::irradiance(double table_angle_deg, const Vec3& point_cam, const Vec3& normal_cam) const {
  const Vec3 to_led = led_position_cam(table_angle_deg) - point_cam;
  const double d2 = to_led.squaredNorm();
  const double cos_i = normal_cam.dot(to_led) / std::sqrt(d2);
  if (cos_i <= 0) return 0.0;
  return led_profile(table_angle_deg, point_cam) * cos_i / d2;
}

Json LightModel::to_json() const {
  const Rigid3 t = cam_from_rig();
  return {{"axis_cam", vector3_to_json(axis_cam)},
          {"origin_cam_m", vector3_to_json(origin_cam)},
          {"arm_radius_m", arm_radius_m},
          {"arm_height_m", arm_height_m},
          {"zero_deg", zero_deg},
          {"profile_exponent", profile_exponent},
          {"cam_from_rig", {{"R", matrix_to_json(t.matrix())}, {"t_m", vector3_to_json(t.translation)}}}};
}

LightModel LightModel::from_json(const Json& j, const std::string& where) {
  LightModel m;
  if (!j.contains("axis_cam") || !j.contains("origin_cam_m"))
    throw DataError(where + ": missing key 'axis_cam' or 'origin_cam_m'");
  m.axis_cam = vector3_from_json(j.at("axis_cam"), where + ": key 'axis_cam'").normalized();
  m.origin_cam = vector3_from_json(j.at("origin_cam_m"), where + ": key 'origin_cam_m'");
  m.arm_radius_m = json_get<double>(j, "arm_radius_m", where);
  m.arm_height_m = json_get<double>(j, "arm_height_m", where);
  m.zero_deg = json_get<double>(j, "zero_deg", where);
  m.profile_exponent = json_get_or<double>(j, "profile_exponent", 0.0, where);
  if (!(m.arm_radius_m > 0)) throw DataError(where + ": key 'arm_radius_m' must be > 0");
  return m;
}

// ---- highlight ----

namespace {

Vec3 mirror(const Vec3& n, const Vec3& v) { return 2.0 * n.dot(v) * n - v; }

}  // namespace

Highlight find_highlight(const HighlightImage& image, const CameraModel& camera, const SphereFit& sphere,
                         const RigGeometry& nominal, const LightOptions& options) {
  options.check();
  Highlight hl;
  hl.table_angle_deg = image.table_angle_deg;
  hl.name = image.name;
  const ImageF& img = image.pixels;
  if (img.width() != camera.width_px || img.height() != camera.height_px || img.channels() != 1)
    throw DataError(fmt::format("light: image '{}' must be one channel of {}x{}", image.name, camera.width_px,
                                camera.height_px));
  const Vec3 C = sphere.centre_cam_m;
  const double R = sphere.radius_m;
  // Bounding box of the sphere's image.
  auto sil = silhouette_points(camera, C, R, 256);
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const Vec2& p : sil) {
    x0 = std::min(x0, p.x());
    x1 = std::max(x1, p.x());
    y0 = std::min(y0, p.y());
    y1 = std::max(y1, p.y());
  }
  const int ix0 = std::max(1, static_cast<int>(std::floor(x0))), ix1 = std::min(img.width() - 2, static_cast<int>(std::ceil(x1)));
  const int iy0 = std::max(1, static_cast<int>(std::floor(y0))), iy1 = std::min(img.height() - 2, static_cast<int>(std::ceil(y1)));
  if (ix1 <= ix0 || iy1 <= iy0) {
    hl.reason = "the sphere is outside the image";
    return hl;
  }
  // Brightest 3x3 median on the sphere (a hot pixel does not win); the noise from
  // differences of horizontal neighbours (the smooth shading of the sphere cancels).
  const double rho_px = camera.fx() * R / C.norm();
  const Vec2 cpx = camera.project(C);
  double best = -1e300;
  int bx = 0, by = 0;
  std::vector<double> on_sphere, diffs;
  for (int y = iy0; y <= iy1; ++y)
    for (int x = ix0; x <= ix1; ++x) {
      if ((Vec2(x, y) - cpx).norm() > 1.02 * rho_px - 2.0) continue;
      if (!intersect_sphere(camera.ray(Vec2(x, y)), C, R)) continue;
      float nb[9];
      int k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) nb[k++] = img.at(x + dx, y + dy);
      const double s = upper_median_inplace(nb);
      // Clipped pixels (+inf, or at saturated_at) can win the peak but not the statistics.
      const double v0 = img.at(x, y), v1 = img.at(x + 1, y);
      if (std::isfinite(v0) && v0 < image.saturated_at) on_sphere.push_back(v0);
      if (std::isfinite(v0) && std::isfinite(v1) && v0 < image.saturated_at && v1 < image.saturated_at)
        diffs.push_back(std::abs(v1 - v0));
      if (s > best) {
        best = s;
        bx = x;
        by = y;
      }
    }
  if (on_sphere.size() < 50 || diffs.empty()) {
    hl.reason = "the sphere is not in the image";
    return hl;
  }
  const double level = upper_median(on_sphere);
  const double noise = std::max(kMadToSigma * upper_median(diffs) / std::sqrt(2.0), 1e-9 * std::abs(best) + 1e-30);
  if (!((best - level) > options.min_snr * noise)) {
    hl.reason = fmt::format("no highlight on the sphere (peak {:.3g} above the sphere's median, noise {:.3g}): is "
                            "the LED on and in front of the sphere's visible side?",
                            best - level, noise);
    return hl;
  }
  // Size at half maximum -> window and starting roughness.
  int half_count = 0;
  const double half = level + 0.5 * (best - level);
  const int probe = 60;
  for (int y = std::max(0, by - probe); y <= std::min(img.height() - 1, by + probe); ++y)
    for (int x = std::max(0, bx - probe); x <= std::min(img.width() - 1, bx + probe); ++x)
      if (img.at(x, y) > half) ++half_count;
  const double r_half = std::sqrt(std::max(1, half_count) / kPi);
  const int hw = options.half_window_px > 0 ? static_cast<int>(options.half_window_px)
                                            : std::clamp(static_cast<int>(std::ceil(3.0 * r_half + 3.0)), 5, 60);
  const double blur = options.blur_sigma_px >= 0 ? options.blur_sigma_px
                                                 : (std::isfinite(sphere.edge_sigma_px) ? sphere.edge_sigma_px : 0.0);
  // Fitted blur: bounded to [0.1, max(1, 2 x start)] px, the kernel wide enough for the bound.
  const double blur_max = std::max(1.0, 2.0 * blur);
  const double blur_start = std::clamp(blur, 0.3, blur_max);
  const int kr = options.fit_blur ? static_cast<int>(std::ceil(3.0 * blur_max))
                                  : (blur > 0.05 ? std::max(1, static_cast<int>(std::ceil(3.0 * blur))) : 0);
  const int side = 2 * hw + 1;
  std::vector<SpherePixel> grid(static_cast<std::size_t>(side * side));
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      const int x = bx - hw + i, y = by - hw + j;
      SpherePixel& p = grid[static_cast<std::size_t>(j * side + i)];
      if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) continue;
      auto X = intersect_sphere(camera.ray(Vec2(x, y)), C, R);
      if (!X) continue;
      p.point = *X;
      p.normal = (*X - C).normalized();
      p.wo = (-*X).normalized();
      p.on_sphere = true;
      p.value = img.at(x, y);
    }
  // Data: on the sphere, with the whole blur footprint on the sphere, not grazing, not clipped.
  int n_data = 0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      SpherePixel& p = grid[static_cast<std::size_t>(j * side + i)];
      if (!p.on_sphere || p.normal.dot(p.wo) < 0.05 || p.value >= image.saturated_at) continue;
      bool inside = true;
      for (int dj = -kr - 1; dj <= kr + 1 && inside; ++dj)
        for (int di = -kr - 1; di <= kr + 1 && inside; ++di) {
          const int ii = i + di, jj = j + dj;
          if (ii < 0 || jj < 0 || ii >= side || jj >= side) continue;
          inside = grid[static_cast<std::size_t>(jj * side + ii)].on_sphere;
        }
      p.data = inside;
      if (inside) ++n_data;
    }
  if (n_data < 12) {
    hl.reason = "the highlight lies on the sphere's silhouette";
    return hl;
  }
  auto X0 = intersect_sphere(camera.ray(Vec2(bx, by)), C, R);
  if (!X0) {
    hl.reason = "the brightest spot is not on the sphere";
    return hl;
  }
  const Vec3 n0 = (*X0 - C).normalized();
  Vec3 e1 = n0.unitOrthogonal(), e2 = n0.cross(e1);
  const double led_distance = std::max(std::hypot(nominal.arm_radius_m, nominal.arm_height_m), 2.0 * R);
  const double cos_o = std::max(0.1, n0.dot((-*X0).normalized()));
  double uv[2] = {0.0, 0.0};
  double logm = std::log(std::clamp(r_half / (0.83 * rho_px * cos_o), 1e-3, 0.3));
  double amp = (best - level) * cos_o, bg = level;
  double logblur = std::log(options.fit_blur ? blur_start : std::max(blur, 0.05));
  ceres::CostFunction* cost = HighlightCost::Create({&grid, side, kr, C, n0, e1, e2, R, led_distance}, n_data);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, uv, &logm, &amp, &bg, &logblur);
  if (options.fit_blur) {
    problem.SetParameterLowerBound(&logblur, 0, std::log(0.1));
    problem.SetParameterUpperBound(&logblur, 0, std::log(blur_max));
  } else {
    problem.SetParameterBlockConstant(&logblur);
  }
  const ceres::Solver::Summary summary = solve_dense(problem, 100, 1e-14, 1e-12);
  const double m = std::exp(logm);
  if (summary.termination_type == ceres::FAILURE || !(amp > options.min_snr * noise * 0.05) || !(m > 1e-4 && m < 0.6)) {
    hl.reason = fmt::format("the highlight model did not fit (roughness {:.3g}, amplitude {:.3g})", m, amp);
    return hl;
  }
  Vec3 ns = (n0 + uv[0] * e1 + uv[1] * e2).normalized();
  const Vec3 Xs = C + R * ns;
  const Vec3 v = (-Xs).normalized();
  const double view_deg = rad_to_deg(std::acos(std::clamp(ns.dot(v), -1.0, 1.0)));
  hl.px = camera.project(Xs);
  hl.roughness = m;
  hl.blur_sigma_px = kr > 0 ? std::exp(logblur) : 0.0;
  hl.point_cam = Xs;
  hl.normal_cam = ns;
  hl.mirror_dir = mirror(ns, v).normalized();
  // Uncertainty of the specular pixel.
  ceres::Covariance::Options co;
  ceres::Covariance cov(co);
  // A blur at its bound (a lobe that does not tell it) is not a parameter of the covariance.
  const bool blur_free = options.fit_blur && logblur > std::log(0.1) + 1e-6 && logblur < std::log(blur_max) - 1e-6;
  if (options.fit_blur && !blur_free) problem.SetParameterBlockConstant(&logblur);
  std::vector<std::pair<const double*, const double*>> blocks = {{uv, uv}};
  if (blur_free) blocks.emplace_back(&logblur, &logblur);
  if (cov.Compute(blocks, &problem)) {
    double c[4];
    cov.GetCovarianceBlock(uv, uv, c);
    const double dof = std::max(1.0, static_cast<double>(n_data) - (blur_free ? 6.0 : 5.0));
    const double s2 = 2.0 * summary.final_cost / dof;
    if (blur_free) {
      double cb = 0;
      cov.GetCovarianceBlock(&logblur, &logblur, &cb);
      hl.blur_std_px = hl.blur_sigma_px * std::sqrt(std::max(0.0, cb * s2));
    }
    Eigen::Matrix2d Cuv;
    Cuv << c[0], c[1], c[2], c[3];
    Cuv *= s2;
    Eigen::Matrix2d J;
    const double h = 1e-7;
    for (int k = 0; k < 2; ++k) {
      double d[2] = {uv[0], uv[1]};
      d[k] += h;
      Vec2 plus = camera.project(C + R * (n0 + d[0] * e1 + d[1] * e2).normalized());
      d[k] -= 2 * h;
      Vec2 minus = camera.project(C + R * (n0 + d[0] * e1 + d[1] * e2).normalized());
      J.col(k) = (plus - minus) / (2 * h);
    }
    const Eigen::Matrix2d Cp = J * Cuv * J.transpose();
    hl.std_px = std::sqrt(0.5 * std::max(0.0, Cp.trace()));
  }
  if (view_deg > options.max_view_angle_deg) {
    hl.reason = fmt::format("the highlight is {:.1f} deg from the sphere's centre as seen from the camera (limit "
                            "{:.0f}): too close to the silhouette",
                            view_deg, options.max_view_angle_deg);
    return hl;
  }
  // In pixels the limb is what counts: there the image is the silhouette's (the pixel's box
  // and the blur across the sphere's edge), not the lobe's. On a sphere 100 px in radius a
  // highlight 76 deg from the centre lies 3.4 px inside the silhouette, and the two such
  // (table angles +-150) moved the arm radius by +1.2 % on the simulated 640x480 rig.
  const double limb_px = rho_px * (1.0 - std::sin(deg_to_rad(view_deg)));
  const double min_limb_px = options.min_limb_distance_px > 0 ? options.min_limb_distance_px : 2.0 * kr + 1.0;
  if (limb_px < min_limb_px) {
    hl.reason = fmt::format("the highlight is {:.1f} px inside the silhouette (limit {:.1f} px): too close to it", limb_px,
                            min_limb_px);
    return hl;
  }
  hl.found = true;
  return hl;
}

// ---- circle fit ----

namespace {


struct CircleParams {
  double ab[2] = {0, 0};
  double uv[2] = {0, 0};
  double rhz[3] = {0, 0, 0};
};

LightModel model_from(const CircleParams& p, const Vec3& centre, const Vec3& a0, const Vec3& e1, const Vec3& e2) {
  LightModel m;
  m.axis_cam = (a0 + p.ab[0] * e1 + p.ab[1] * e2).normalized();
  Vec3 off = p.uv[0] * e1 + p.uv[1] * e2;
  off -= off.dot(m.axis_cam) * m.axis_cam;
  m.origin_cam = centre + off;
  m.arm_radius_m = p.rhz[0];
  m.arm_height_m = p.rhz[1];
  m.zero_deg = rad_to_deg(p.rhz[2]);
  return m;
}

}  // namespace

// Angle (deg) between the observed ray and the model's direction, and its component along
// the circle: the observed ray is intersected with the LED circle's cylinder.
void highlight_residual(const LightModel& m, Highlight* h) {
  const Vec3 L = m.led_position_cam(h->table_angle_deg);
  h->residual_deg = rad_to_deg(angle_between(L - h->point_cam, h->mirror_dir));
  const Rigid3 rig_from_cam = m.cam_from_rig().inverse();
  const Vec3 p = rig_from_cam * h->point_cam;
  const Vec3 d = rig_from_cam.rotation * h->mirror_dir;
  // |p_xy + t d_xy| = R
  const double A = d.x() * d.x() + d.y() * d.y();
  const double B = 2 * (p.x() * d.x() + p.y() * d.y());
  const double Cc = p.x() * p.x() + p.y() * p.y() - m.arm_radius_m * m.arm_radius_m;
  const double disc = B * B - 4 * A * Cc;
  if (A > 0 && disc >= 0) {
    const double t = (-B + std::sqrt(disc)) / (2 * A);
    const Vec3 q = p + t * d;
    h->azimuth_error_deg = angle_diff_deg(rad_to_deg(std::atan2(q.y(), q.x())), h->table_angle_deg + m.zero_deg);
  }
}

LightCalibration fit_light_model(std::vector<Highlight> highlights, const SphereFit& sphere, const RigGeometry& nominal,
                                 const LightOptions& options) {
  options.check();
  LightCalibration cal;
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < highlights.size(); ++i)
    if (highlights[i].found) idx.push_back(i);
  auto failures = [&]() {
    std::string s;
    for (const auto& h : highlights)
      if (!h.found) s += fmt::format("\n  {} ({:g} deg): {}", h.name, h.table_angle_deg, h.reason);
    return s;
  };
  if (idx.size() < 4)
    throw CalibrationError(fmt::format("light: highlights found at only {} of {} table angles (at least 4 needed){}",
                                       idx.size(), highlights.size(), failures()));
  const Vec3 C = sphere.centre_cam_m;
  // Start: each ray meets the sphere of the nominal LED distance about C; a plane through
  // those points gives the axis, a circle in it the rest.
  const double dist0 = std::hypot(nominal.arm_radius_m, nominal.arm_height_m);
  std::vector<Vec3> pts;
  for (std::size_t i : idx) {
    const Highlight& h = highlights[i];
    const Vec3 p = h.point_cam - C;
    const double b = p.dot(h.mirror_dir), c = p.squaredNorm() - dist0 * dist0;
    const double t = -b + std::sqrt(std::max(0.0, b * b - c));
    pts.push_back(h.point_cam + t * h.mirror_dir);
  }
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : pts) mean += p / static_cast<double>(pts.size());
  Eigen::MatrixXd A(pts.size(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) A.row(static_cast<Eigen::Index>(i)) = (pts[i] - mean).transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinV);
  Vec3 a0 = svd.matrixV().col(2);
  // "Up" from the nominal camera pitch: the camera looks down at the sphere.
  const double beta = std::asin(std::clamp(nominal.camera_height_m / nominal.camera_distance_m, -1.0, 1.0));
  const Vec3 up_nominal(0.0, -std::cos(beta), -std::sin(beta));
  if (a0.dot(up_nominal) < 0) a0 = -a0;
  if (a0.dot(up_nominal) < 0.5) a0 = up_nominal;  // angles spanning too short an arc: trust the drawing
  Vec3 e1 = a0.unitOrthogonal(), e2 = a0.cross(e1);
  CircleParams p;
  // Circle centre in the plane: least squares (Kasa) in (e1, e2) coordinates.
  {
    Eigen::MatrixXd M(pts.size(), 3);
    Eigen::VectorXd rhs(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double x = (pts[i] - C).dot(e1), y = (pts[i] - C).dot(e2);
      M(static_cast<Eigen::Index>(i), 0) = x;
      M(static_cast<Eigen::Index>(i), 1) = y;
      M(static_cast<Eigen::Index>(i), 2) = 1.0;
      rhs(static_cast<Eigen::Index>(i)) = x * x + y * y;
    }
    Eigen::Vector3d s = M.colPivHouseholderQr().solve(rhs);
    const double cx = 0.5 * s(0), cy = 0.5 * s(1);
    const double r = std::sqrt(std::max(1e-6, s(2) + cx * cx + cy * cy));
    // Few angles over a short arc make this unstable: keep it only when plausible.
    if (std::hypot(cx, cy) < 0.25 * nominal.arm_radius_m && r > 0.5 * nominal.arm_radius_m && r < 2.0 * nominal.arm_radius_m) {
      p.uv[0] = cx;
      p.uv[1] = cy;
      p.rhz[0] = r;
    } else {
      p.rhz[0] = nominal.arm_radius_m;
    }
  }
  p.rhz[1] = (mean - C).dot(a0);
  {
    // Zero offset: circular mean of (azimuth - table angle).
    LightModel m0 = model_from(p, C, a0, e1, e2);
    const Rigid3 rig_from_cam = m0.cam_from_rig().inverse();
    double s = 0, c = 0;
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const Vec3 q = rig_from_cam * pts[k];
      const double d = std::atan2(q.y(), q.x()) - deg_to_rad(highlights[idx[k]].table_angle_deg);
      s += std::sin(d);
      c += std::cos(d);
    }
    p.rhz[2] = std::atan2(s, c);
  }

  std::vector<bool> use(highlights.size(), false);
  for (std::size_t i : idx) use[i] = true;
  ceres::Solver::Summary summary;
  std::unique_ptr<ceres::Problem> problem;
  for (int round = 0; round < 3; ++round) {
    problem = std::make_unique<ceres::Problem>();
    int n = 0;
    for (std::size_t i = 0; i < highlights.size(); ++i) {
      if (!use[i]) continue;
      const Highlight& h = highlights[i];
      Vec3 t1 = h.mirror_dir.unitOrthogonal(), t2 = h.mirror_dir.cross(t1);
      problem->AddResidualBlock(LedCircleCost::Create({h.point_cam, h.mirror_dir, t1, t2, deg_to_rad(h.table_angle_deg), C, a0, e1, e2}),
                                round == 0 ? new ceres::HuberLoss(deg_to_rad(0.05)) : nullptr, p.ab, p.uv, p.rhz);
      ++n;
    }
    if (n < 4)
      throw CalibrationError(fmt::format("light: only {} highlights agree with one LED circle (at least 4 needed){}", n,
                                         failures()));
    problem->SetParameterLowerBound(p.rhz, 0, 2.0 * sphere.radius_m);
    summary = solve_dense(*problem, 200, 1e-15, 1e-14, 1e-16);
    if (summary.termination_type == ceres::FAILURE)
      throw CalibrationError("light: the LED circle fit failed: " + summary.BriefReport());
    const LightModel m = model_from(p, C, a0, e1, e2);
    std::vector<double> res;
    for (std::size_t i = 0; i < highlights.size(); ++i) {
      if (!highlights[i].found) continue;
      highlight_residual(m, &highlights[i]);
      if (use[i]) res.push_back(highlights[i].residual_deg);
    }
    double limit = options.outlier_deg;
    if (limit <= 0) limit = std::max(0.02, 5.0 * kMadToSigma * upper_median(res));
    bool changed = false;
    for (std::size_t i = 0; i < highlights.size(); ++i) {
      if (!highlights[i].found) continue;
      const bool ok = highlights[i].residual_deg <= limit;
      if (ok != use[i]) changed = true;
      use[i] = ok;
      highlights[i].reason =
          ok ? "" : fmt::format("off the LED circle by {:.3f} deg (limit {:.3f}): a reflection that is not the LED?",
                                highlights[i].residual_deg, limit);
    }
    if (!changed && round > 0) break;
  }
  cal.model = model_from(p, C, a0, e1, e2);
  double ss = 0;
  for (std::size_t i = 0; i < highlights.size(); ++i) {
    highlights[i].used = use[i] && highlights[i].found;
    if (!highlights[i].used) continue;
    ++cal.used;
    ss += highlights[i].residual_deg * highlights[i].residual_deg;
    cal.max_deg = std::max(cal.max_deg, highlights[i].residual_deg);
  }
  cal.rms_deg = std::sqrt(ss / std::max(1, cal.used));
  // Uncertainty: covariance scaled by the residual variance.
  {
    ceres::Covariance::Options co;
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks = {{p.rhz, p.rhz}, {p.ab, p.ab}};
    if (cov.Compute(blocks, problem.get())) {
      double c[9], cab[4];
      cov.GetCovarianceBlock(p.rhz, p.rhz, c);
      cov.GetCovarianceBlock(p.ab, p.ab, cab);
      const double dof = std::max(1.0, 2.0 * cal.used - 7.0);
      const double s2 = 2.0 * summary.final_cost / dof;
      cal.arm_radius_std_m = std::sqrt(std::max(0.0, c[0] * s2));
      cal.arm_height_std_m = std::sqrt(std::max(0.0, c[4] * s2));
      cal.zero_std_deg = rad_to_deg(std::sqrt(std::max(0.0, c[8] * s2)));
      cal.axis_std_deg = rad_to_deg(std::sqrt(std::max(0.0, 0.5 * (cab[0] + cab[3]) * s2)));
    }
  }
  cal.highlights = std::move(highlights);
  cal.provenance = Provenance::make("light", {});
  return cal;
}

LightCalibration calibrate_light(const std::vector<HighlightImage>& images, const CameraModel& camera,
                                 const SphereFit& sphere, const RigGeometry& nominal, const LightOptions& options) {
  const double sphere_blur = std::isfinite(sphere.edge_sigma_px) ? sphere.edge_sigma_px : 0.0;
  std::vector<Highlight> hs;
  double blur = options.blur_sigma_px >= 0 ? options.blur_sigma_px : sphere_blur, blur_std = 0.0;
  std::string source = options.blur_sigma_px >= 0 ? "given" : "sphere";
  if (options.blur_sigma_px < 0 && options.common_blur && !options.fit_blur) {
    // Pass 1: every lobe with its own blur; their weighted mean is the optics' blur.
    LightOptions o1 = options;
    o1.fit_blur = true;
    std::vector<double> b, w;
    for (const auto& im : images) {
      const Highlight h = find_highlight(im, camera, sphere, nominal, o1);
      if (h.found && h.blur_std_px > 0 && std::isfinite(h.blur_std_px) && h.blur_sigma_px > 0.11) {
        b.push_back(h.blur_sigma_px);
        w.push_back(1.0 / (h.blur_std_px * h.blur_std_px));
      }
    }
    if (b.size() >= 3) {
      // A lobe whose blur is far off the others' (a double reflection, dust) does not count.
      const double med = upper_median(b);
      double sw = 0, swb = 0;
      for (std::size_t i = 0; i < b.size(); ++i) {
        if (std::abs(b[i] - med) > std::max(0.25 * med, 4.0 / std::sqrt(w[i]))) continue;
        sw += w[i];
        swb += w[i] * b[i];
      }
      if (sw > 0) {
        blur = swb / sw;
        blur_std = 1.0 / std::sqrt(sw);
        source = "highlights";
      }
    }
  }
  LightOptions o2 = options;
  o2.blur_sigma_px = blur;
  for (const auto& im : images) hs.push_back(find_highlight(im, camera, sphere, nominal, o2));
  LightCalibration cal = fit_light_model(std::move(hs), sphere, nominal, o2);
  cal.blur_sigma_px = blur;
  cal.blur_std_px = blur_std;
  cal.blur_source = source;
  return cal;
}

// ---- JSON ----

Json LightCalibration::to_json() const {
  Json hs = Json::array();
  for (const auto& h : highlights) {
    Json o = {{"table_angle_deg", h.table_angle_deg}, {"name", h.name}, {"found", h.found}, {"used", h.used}};
    if (!h.reason.empty()) o["reason"] = h.reason;
    if (h.found) {
      o["px"] = Json::array({h.px.x(), h.px.y()});
      o["std_px"] = h.std_px;
      o["roughness"] = h.roughness;
      o["blur_sigma_px"] = h.blur_sigma_px;
      o["residual_deg"] = h.residual_deg;
      o["azimuth_error_deg"] = h.azimuth_error_deg;
    }
    hs.push_back(o);
  }
  Json j = model.to_json();
  j["rms_deg"] = rms_deg;
  j["max_deg"] = max_deg;
  j["used"] = used;
  j["std"] = {{"arm_radius_m", arm_radius_std_m},
              {"arm_height_m", arm_height_std_m},
              {"zero_deg", zero_std_deg},
              {"axis_deg", axis_std_deg}};
  j["highlight_blur"] = {{"sigma_px", blur_sigma_px}, {"std_px", blur_std_px}, {"source", blur_source}};
  j["highlights"] = hs;
  j["provenance"] = provenance.to_json();
  return j;
}

LightCalibration LightCalibration::from_json(const Json& j, const std::string& where) {
  LightCalibration c;
  c.model = LightModel::from_json(j, where);
  c.rms_deg = json_get<double>(j, "rms_deg", where);
  c.max_deg = json_get_or<double>(j, "max_deg", 0.0, where);
  c.used = json_get_or<int>(j, "used", 0, where);
  if (j.contains("std")) {
    const Json& s = j.at("std");
    c.arm_radius_std_m = json_get_or<double>(s, "arm_radius_m", 0.0, where);
    c.arm_height_std_m = json_get_or<double>(s, "arm_height_m", 0.0, where);
    c.zero_std_deg = json_get_or<double>(s, "zero_deg", 0.0, where);
    c.axis_std_deg = json_get_or<double>(s, "axis_deg", 0.0, where);
  }
  if (j.contains("highlight_blur")) {
    const Json& b = j.at("highlight_blur");
    c.blur_sigma_px = json_get_or<double>(b, "sigma_px", 0.0, where);
    c.blur_std_px = json_get_or<double>(b, "std_px", 0.0, where);
    c.blur_source = json_get_or<std::string>(b, "source", "", where);
  }
  if (j.contains("highlights"))
    for (const Json& o : j.at("highlights")) {
      Highlight h;
      h.table_angle_deg = json_get<double>(o, "table_angle_deg", where);
      h.name = json_get_or<std::string>(o, "name", "", where);
      h.found = json_get_or<bool>(o, "found", false, where);
      h.used = json_get_or<bool>(o, "used", false, where);
      h.reason = json_get_or<std::string>(o, "reason", "", where);
      h.residual_deg = json_get_or<double>(o, "residual_deg", 0.0, where);
      h.azimuth_error_deg = json_get_or<double>(o, "azimuth_error_deg", 0.0, where);
      h.std_px = json_get_or<double>(o, "std_px", 0.0, where);
      h.roughness = json_get_or<double>(o, "roughness", 0.0, where);
      h.blur_sigma_px = json_get_or<double>(o, "blur_sigma_px", 0.0, where);
      if (o.contains("px")) {
        auto v = json_get<std::vector<double>>(o, "px", where);
        if (v.size() == 2) h.px = Vec2(v[0], v[1]);
      }
      c.highlights.push_back(h);
    }
  if (j.contains("provenance")) c.provenance = Provenance::from_json(j.at("provenance"), where);
  return c;
}

void LightCalibration::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

LightCalibration LightCalibration::load(const std::filesystem::path& path) {
  return from_json(read_json_file(path), path.string());
}

}  // namespace paintlab::calib
