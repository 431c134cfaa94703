#include "paintlab/calibration/intrinsics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <cmath>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "paintlab/calibration/cost_functions.h"
#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "dense_solve.h"

namespace paintlab::calib {

void IntrinsicsOptions::check() const {
  corners.check();
  if (!(outlier_factor > 1.0)) throw UsageError("intrinsics: outlier_factor must be > 1");
  if (!(outlier_min_px > 0.0)) throw UsageError("intrinsics: outlier_min_px must be > 0");
  if (!(max_fallback_frac >= 0.0 && max_fallback_frac <= 1.0))
    throw UsageError("intrinsics: max_fallback_frac must be in [0, 1]");
  if (min_views < 3) throw UsageError("intrinsics: min_views must be >= 3 (got " + std::to_string(min_views) + ")");
  if (initial_focal_px < 0) throw UsageError("intrinsics: initial_focal_px must be >= 0");
  if (!(k3_significance >= 0.0)) throw UsageError("intrinsics: k3_significance must be >= 0");
}

namespace {

struct Solution {
  cv::Mat K, D;
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat std_intr;
  double rms = 0;
};

std::vector<cv::Point3f> cv_object_points(const BoardSpec& board) {
  std::vector<cv::Point3f> out;
  for (const Vec3& p : board.object_points())
    out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  return out;
}

std::vector<cv::Point2f> cv_points(const std::vector<Vec2>& v) {
  std::vector<cv::Point2f> out;
  out.reserve(v.size());
  for (const Vec2& p : v) out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  return out;
}


// OpenCV's Levenberg-Marquardt stops early in the flat valleys of long lenses (measured on
// the simulated 50 mm rig: two starts ended 0.45 % apart in focal length and 6 px apart in
// the principal point, each claiming a 0.002 px standard deviation). A Ceres bundle
// adjustment from its result converges fully; the covariance of the intrinsics is then
// taken with the poses marginalised (the full normal matrix, pseudo-inverted by SVD) and
// scaled by the residual variance.
void refine(const std::vector<const CornerView*>& views, const BoardSpec& board, bool fix_k3, Solution* s) {
  double in[9] = {s->K.at<double>(0, 0), s->K.at<double>(1, 1), s->K.at<double>(0, 2), s->K.at<double>(1, 2),
                  s->D.at<double>(0),    s->D.at<double>(1),    s->D.at<double>(2),    s->D.at<double>(3),
                  s->D.at<double>(4)};
  std::vector<std::array<double, 6>> poses(views.size());
  for (std::size_t k = 0; k < views.size(); ++k)
    for (int i = 0; i < 3; ++i) {
      poses[k][static_cast<std::size_t>(i)] = s->rvecs[k].at<double>(i);
      poses[k][static_cast<std::size_t>(i + 3)] = s->tvecs[k].at<double>(i);
    }
  const auto obj = board.object_points();
  ceres::Problem problem;
  int n = 0;
  for (std::size_t k = 0; k < views.size(); ++k)
    for (std::size_t i = 0; i < obj.size(); ++i, ++n)
      problem.AddResidualBlock(ReprojectionCost::Create(obj[i].x(), obj[i].y(), views[k]->corners_px[i].x(),
                                                        views[k]->corners_px[i].y()),
                               nullptr, in, poses[k].data());
  if (fix_k3) {
    in[8] = 0.0;
    problem.SetManifold(in, new ceres::SubsetManifold(9, {8}));
  }
  const ceres::Solver::Summary summary = solve_dense(problem, 500, 1e-16, 1e-16, 1e-20, ceres::DENSE_SCHUR);
  if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost)) return;  // keep OpenCV's
  const double rms = std::sqrt(2.0 * summary.final_cost / n);
  if (!(rms <= s->rms * 1.0001 + 1e-12)) return;
  s->rms = rms;
  s->K = (cv::Mat_<double>(3, 3) << in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1);
  s->D = (cv::Mat_<double>(5, 1) << in[4], in[5], in[6], in[7], in[8]);
  for (std::size_t k = 0; k < views.size(); ++k) {
    s->rvecs[k] = (cv::Mat_<double>(3, 1) << poses[k][0], poses[k][1], poses[k][2]);
    s->tvecs[k] = (cv::Mat_<double>(3, 1) << poses[k][3], poses[k][4], poses[k][5]);
  }
  // Covariance: the dense normal matrix of all parameters with its columns scaled to unit
  // norm (fx ~ 1e4 px next to k3 ~ 1e-2), inverted, the intrinsic block taken.
  ceres::CRSMatrix crs;
  std::vector<double*> blocks = {in};
  for (auto& p : poses) blocks.push_back(p.data());
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  double cost = 0;
  if (!problem.Evaluate(eo, &cost, nullptr, nullptr, &crs)) return;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[static_cast<std::size_t>(r)]; k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k)
      J(r, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
  Eigen::VectorXd scale = J.colwise().norm();
  for (Eigen::Index c = 0; c < scale.size(); ++c)
    if (scale(c) > 0) J.col(c) /= scale(c);
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  const Eigen::MatrixXd inv = JtJ.completeOrthogonalDecomposition().pseudoInverse();
  // With k3 held, the intrinsics block has 8 columns (k3, the last, is not a parameter).
  const int ni = fix_k3 ? 8 : 9;
  const double dof = std::max(1.0, 2.0 * n - ni - 6.0 * static_cast<double>(views.size()));
  const double s2 = 2.0 * cost / dof;
  s->std_intr = cv::Mat::zeros(18, 1, CV_64F);
  for (int i = 0; i < ni; ++i)
    s->std_intr.at<double>(i) = scale(i) > 0 ? std::sqrt(std::max(0.0, inv(i, i) * s2)) / scale(i) : 0.0;
}

Solution solve(const std::vector<const CornerView*>& views, const BoardSpec& board, cv::Size size,
               const IntrinsicsOptions& options) {
  std::vector<std::vector<cv::Point3f>> obj(views.size(), cv_object_points(board));
  std::vector<std::vector<cv::Point2f>> img;
  for (const CornerView* v : views) img.push_back(cv_points(v->corners_px));
  Solution s;
  int flags = 0;
  if (options.initial_focal_px > 0) {
    s.K = (cv::Mat_<double>(3, 3) << options.initial_focal_px, 0, (size.width - 1) * 0.5, 0, options.initial_focal_px,
           (size.height - 1) * 0.5, 0, 0, 1);
    s.D = cv::Mat::zeros(5, 1, CV_64F);
    flags |= cv::CALIB_USE_INTRINSIC_GUESS;
  }
  if (options.fix_k3) flags |= cv::CALIB_FIX_K3;
  cv::Mat std_extr, per_view;
  try {
    s.rms = cv::calibrateCamera(obj, img, size, s.K, s.D, s.rvecs, s.tvecs, s.std_intr, std_extr, per_view, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  } catch (const cv::Exception& e) {
    throw CalibrationError(std::string("intrinsics: OpenCV calibrateCamera failed: ") + e.what());
  }
  if (!std::isfinite(s.rms)) throw CalibrationError("intrinsics: the camera solve diverged (RMS not finite)");
  refine(views, board, options.fix_k3, &s);
  return s;
}

CameraModel to_model(const Solution& s, cv::Size size) {
  CameraModel m;
  m.width_px = size.width;
  m.height_px = size.height;
  Eigen::Matrix3d K;
  cv::cv2eigen(s.K, K);
  m.K = K;
  for (int i = 0; i < 5; ++i) m.dist[static_cast<std::size_t>(i)] = s.D.at<double>(i);
  return m;
}

Rigid3 to_rigid(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  Rigid3 t;
  t.rotation = Eigen::Quaterniond(Re);
  t.translation = Vec3(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return t;
}

// Residuals of one view for a pose: RMS and max in px.
std::pair<double, double> view_error(const CornerView& v, const BoardSpec& board, const cv::Mat& rvec,
                                     const cv::Mat& tvec, const cv::Mat& K, const cv::Mat& D,
                                     std::vector<Vec2>* residuals = nullptr) {
  std::vector<cv::Point2f> proj;
  cv::projectPoints(cv_object_points(board), rvec, tvec, K, D, proj);
  double ss = 0, mx = 0;
  if (residuals) residuals->clear();
  for (std::size_t i = 0; i < proj.size(); ++i) {
    const double dx = proj[i].x - v.corners_px[i].x(), dy = proj[i].y - v.corners_px[i].y();
    if (residuals) residuals->emplace_back(-dx, -dy);
    const double e2 = dx * dx + dy * dy;
    ss += e2;
    mx = std::max(mx, std::sqrt(e2));
  }
  return {std::sqrt(ss / static_cast<double>(proj.size())), mx};
}

// 0 for none (the result fields' "not measured"), not upper_median()'s NaN.
double upper_median_or_zero(const std::vector<double>& v) { return v.empty() ? 0.0 : upper_median(v); }

IntrinsicsResult calibrate_views(const std::vector<CornerView>& views, std::vector<ViewReport> reports,
                                 const BoardSpec& board, cv::Size size, const IntrinsicsOptions& options) {
  options.check();
  board.check();
  IntrinsicsResult res;
  res.board = board;
  res.corner_method = options.corners.method;
  std::vector<std::size_t> used;
  for (std::size_t i = 0; i < views.size(); ++i) {
    if (!reports[i].detected) continue;
    if (views[i].corners_px.size() != static_cast<std::size_t>(board.corner_count()))
      throw DataError("intrinsics: view '" + views[i].name + "' has " + std::to_string(views[i].corners_px.size()) +
                      " corners, the board " + std::to_string(board.corner_count()));
    if (reports[i].reason.empty()) used.push_back(i);
  }
  auto names_of_dropped = [&]() {
    std::string s;
    for (const auto& r : reports)
      if (!r.used && !r.reason.empty()) s += fmt::format("\n  {}: {}", r.name, r.reason);
    return s;
  };
  auto need_views = [&]() {
    if (static_cast<int>(used.size()) < options.min_views)
      throw CalibrationError(fmt::format("intrinsics: only {} usable chessboard views of {} (at least {} needed){}",
                                         used.size(), views.size(), options.min_views, names_of_dropped()));
  };
  need_views();

  // Drop the worst outlier view, re-solve, and re-admit dropped views that fit the new
  // camera (a bad view can make a good one look bad before it is removed itself).
  Solution sol;
  std::vector<std::size_t> outliers;
  for (std::size_t round = 0; round < 2 * views.size() + 2; ++round) {
    std::vector<const CornerView*> vs;
    for (std::size_t i : used) vs.push_back(&views[i]);
    sol = solve(vs, board, size, options);
    std::vector<double> rms;
    for (std::size_t k = 0; k < used.size(); ++k)
      rms.push_back(view_error(views[used[k]], board, sol.rvecs[k], sol.tvecs[k], sol.K, sol.D).first);
    const double med = upper_median_or_zero(rms);
    const double limit = std::max(options.outlier_factor * med, options.outlier_min_px);
    bool readmitted = false;
    for (auto it = outliers.begin(); it != outliers.end();) {
      cv::Mat rvec, tvec;
      if (cv::solvePnP(cv_object_points(board), cv_points(views[*it].corners_px), sol.K, sol.D, rvec, tvec) &&
          view_error(views[*it], board, rvec, tvec, sol.K, sol.D).first <= limit) {
        reports[*it].reason.clear();
        used.push_back(*it);
        it = outliers.erase(it);
        readmitted = true;
      } else {
        ++it;
      }
    }
    if (readmitted) {
      std::sort(used.begin(), used.end());
      continue;
    }
    std::size_t worst = 0;
    for (std::size_t k = 1; k < rms.size(); ++k)
      if (rms[k] > rms[worst]) worst = k;
    if (rms[worst] <= limit || static_cast<int>(used.size()) <= options.min_views) break;
    reports[used[worst]].reason =
        fmt::format("reprojection RMS {:.3f} px exceeds max({} x median {:.3f}, {}) px: the board moved or bent "
                    "during the shot, or the detection is wrong",
                    rms[worst], options.outlier_factor, med, options.outlier_min_px);
    outliers.push_back(used[worst]);
    used.erase(used.begin() + static_cast<std::ptrdiff_t>(worst));
    need_views();
  }

  res.camera = to_model(sol, size);
  std::vector<double> blur;
  double ss = 0;
  int n = 0;
  for (std::size_t k = 0; k < used.size(); ++k) {
    ViewReport& r = reports[used[k]];
    r.used = true;
    auto [rms, mx] = view_error(views[used[k]], board, sol.rvecs[k], sol.tvecs[k], sol.K, sol.D, &r.residuals_px);
    r.rms_px = rms;
    r.max_px = mx;
    r.cam_from_board = to_rigid(sol.rvecs[k], sol.tvecs[k]);
    ss += rms * rms * board.corner_count();
    n += board.corner_count();
    res.worst_px = std::max(res.worst_px, mx);
    if (r.blur_sigma_px > 0) blur.push_back(r.blur_sigma_px);
  }
  res.rms_px = std::sqrt(ss / n);
  res.views_used = static_cast<int>(used.size());
  res.blur_sigma_px = upper_median_or_zero(blur);
  // Dropped but detected views: their error against the final camera with their own pose.
  for (std::size_t i = 0; i < views.size(); ++i) {
    ViewReport& r = reports[i];
    if (r.used || !r.detected) continue;
    cv::Mat rvec, tvec;
    std::vector<cv::Point2f> img = cv_points(views[i].corners_px);
    if (cv::solvePnP(cv_object_points(board), img, sol.K, sol.D, rvec, tvec)) {
      auto [rms, mx] = view_error(views[i], board, rvec, tvec, sol.K, sol.D, &r.residuals_px);
      r.rms_px = rms;
      r.max_px = mx;
      r.cam_from_board = to_rigid(rvec, tvec);
    }
  }
  for (const auto& r : reports)
    if (!r.used) ++res.views_dropped;
  res.std.fx = sol.std_intr.at<double>(0);
  res.std.fy = sol.std_intr.at<double>(1);
  res.std.cx = sol.std_intr.at<double>(2);
  res.std.cy = sol.std_intr.at<double>(3);
  const int order[5] = {4, 5, 6, 7, 8};  // k1, k2, p1, p2, k3
  for (int i = 0; i < 5; ++i) res.std.dist[static_cast<std::size_t>(i)] = sol.std_intr.at<double>(order[i]);
  res.views = std::move(reports);
  res.provenance = Provenance::make("intrinsics", {});
  return res;
}

// calibrate_views with k3 free, fixed, or decided from the free solution's uncertainty.
IntrinsicsResult calibrate_views_k3(const std::vector<CornerView>& views, const std::vector<ViewReport>& reports,
                                    const BoardSpec& board, cv::Size size, const IntrinsicsOptions& options) {
  if (options.fix_k3 || !options.auto_fix_k3) {
    IntrinsicsResult r = calibrate_views(views, reports, board, size, options);
    r.k3.mode = options.fix_k3 ? "fixed" : "free";
    r.k3.fixed = options.fix_k3;
    if (options.fix_k3) r.k3.note = "k3 fixed at 0 (asked for)";
    return r;
  }
  IntrinsicsResult free = calibrate_views(views, reports, board, size, options);
  const double k3 = free.camera.dist[4], sd = free.std.dist[4];
  free.k3.mode = "auto";
  free.k3.free_value = k3;
  free.k3.free_std = sd;
  if (std::abs(k3) > options.k3_significance * sd) {
    free.k3.note = fmt::format("k3 fitted: {:.4g} +- {:.4g} (more than {:g} standard deviations from 0)", k3, sd,
                               options.k3_significance);
    return free;
  }
  IntrinsicsOptions o = options;
  o.fix_k3 = true;
  o.auto_fix_k3 = false;
  IntrinsicsResult fixed = calibrate_views(views, reports, board, size, o);
  fixed.k3 = free.k3;
  fixed.k3.fixed = true;
  fixed.k3.note = fmt::format("k3 fixed at 0: the free fit gave k3 = {:.4g} +- {:.4g}, within {:g} standard deviations "
                              "of 0 (not determined by these views: a narrow field of view, or the views miss the "
                              "image's corners)",
                              k3, sd, options.k3_significance);
  return fixed;
}

}  // namespace

IntrinsicsResult calibrate_from_corners(const std::vector<CornerView>& views, const BoardSpec& board, int width_px,
                                        int height_px, const IntrinsicsOptions& options) {
  std::vector<ViewReport> reports(views.size());
  for (std::size_t i = 0; i < views.size(); ++i) {
    reports[i].name = views[i].name;
    reports[i].detected = !views[i].corners_px.empty();
    if (!reports[i].detected) reports[i].reason = "no chessboard corners";
    reports[i].corners_px = views[i].corners_px;
    reports[i].blur_sigma_px = views[i].blur_sigma_px;
    reports[i].contrast = views[i].contrast;
  }
  return calibrate_views_k3(views, reports, board, cv::Size(width_px, height_px), options);
}

IntrinsicsResult calibrate_intrinsics(const std::vector<BoardImage>& images, const BoardSpec& board,
                                      const IntrinsicsOptions& options) {
  options.check();
  board.check();
  if (images.empty()) throw UsageError("intrinsics: no chessboard images given");
  const int w = images.front().pixels.width(), h = images.front().pixels.height();
  int bit_depth = 8;
  std::vector<CornerView> views(images.size());
  std::vector<ViewReport> reports(images.size());
  std::vector<std::vector<double>> corner_std(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    const BoardImage& im = images[i];
    if (im.pixels.width() != w || im.pixels.height() != h)
      throw DataError(fmt::format("intrinsics: image '{}' is {}x{}, the first one ({}) {}x{}", im.name,
                                  im.pixels.width(), im.pixels.height(), images.front().name, w, h));
    bit_depth = std::max(bit_depth, im.bit_depth);
    ChessboardDetection det = detect_chessboard(im.pixels, im.bit_depth, board, options.corners);
    ViewReport& r = reports[i];
    r.name = views[i].name = im.name;
    r.detected = det.found;
    if (!det.found) {
      r.reason = det.reason;
      continue;
    }
    views[i].corners_px = det.corners_px;
    r.corners_px = det.corners_px;
    r.blur_sigma_px = views[i].blur_sigma_px = std::isfinite(det.blur_sigma_px) ? det.blur_sigma_px : 0.0;
    r.contrast = views[i].contrast = std::isfinite(det.contrast) ? det.contrast : 0.0;
    r.fallback_corners = det.fallback;
    corner_std[i] = det.corner_std_px;
    if (options.corners.method == CornerMethod::SaddleFit &&
        det.fallback > options.max_fallback_frac * board.corner_count())
      r.reason = fmt::format("the corner model fit failed for {} of {} corners (blurred, glare or low contrast)",
                             det.fallback, board.corner_count());
  }
  IntrinsicsResult res = calibrate_views_k3(views, reports, board, cv::Size(w, h), options);
  res.bit_depth = bit_depth;
  // Corner localisation uncertainty: median over the fitted corners of used views.
  std::vector<double> stds;
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (!res.views[i].used) continue;
    for (double s : corner_std[i])
      if (std::isfinite(s)) stds.push_back(s);
  }
  res.median_corner_std_px = upper_median_or_zero(stds);
  return res;
}

// ---- JSON ----

Json IntrinsicsResult::to_json() const {
  Json j = camera.to_json();
  j["rms_px"] = rms_px;
  j["worst_px"] = worst_px;
  j["views_used"] = views_used;
  j["views_dropped"] = views_dropped;
  j["std"] = {{"fx", std.fx},
              {"fy", std.fy},
              {"cx", std.cx},
              {"cy", std.cy},
              {"dist", Json::array({std.dist[0], std.dist[1], std.dist[2], std.dist[3], std.dist[4]})}};
  {
    Json k = {{"mode", k3.mode}, {"fixed", k3.fixed}};
    if (std::isfinite(k3.free_value)) k["free_fit"] = {{"k3", k3.free_value}, {"std", k3.free_std}};
    if (!k3.note.empty()) k["note"] = k3.note;
    j["k3"] = k;
  }
  j["board"] = {{"cols", board.cols}, {"rows", board.rows}, {"square_m", board.square_m}};
  j["corner_method"] = to_string(corner_method);
  j["bit_depth"] = bit_depth;
  j["blur_sigma_px"] = blur_sigma_px;
  j["median_corner_std_px"] = median_corner_std_px;
  Json vs = Json::array();
  for (const ViewReport& v : views) {
    Json o = {{"name", v.name}, {"detected", v.detected}, {"used", v.used}};
    if (!v.reason.empty()) o["reason"] = v.reason;
    if (v.detected) {
      o["rms_px"] = v.rms_px;
      o["max_px"] = v.max_px;
      o["blur_sigma_px"] = v.blur_sigma_px;
      o["contrast"] = v.contrast;
      o["fallback_corners"] = v.fallback_corners;
      // To 0.1 millipixel: far below the corners' own noise, and a third of the digits.
      const auto points = [](const std::vector<Vec2>& p) {
        Json a = Json::array();
        for (const Vec2& q : p) a.push_back({std::round(q.x() * 1e4) / 1e4, std::round(q.y() * 1e4) / 1e4});
        return a;
      };
      if (!v.residuals_px.empty()) {
        o["corners_px"] = points(v.corners_px);
        o["residuals_px"] = points(v.residuals_px);
      }
      o["cam_from_board"] = {{"rotation_xyzw", Json::array({v.cam_from_board.rotation.x(), v.cam_from_board.rotation.y(),
                                                            v.cam_from_board.rotation.z(), v.cam_from_board.rotation.w()})},
                             {"translation_m", vector3_to_json(v.cam_from_board.translation)}};
    }
    vs.push_back(o);
  }
  j["views"] = vs;
  j["provenance"] = provenance.to_json();
  return j;
}

IntrinsicsResult IntrinsicsResult::from_json(const Json& j, const std::string& where) {
  IntrinsicsResult r;
  r.camera = CameraModel::from_json(j, where);
  r.rms_px = json_get<double>(j, "rms_px", where);
  r.worst_px = json_get_or<double>(j, "worst_px", 0.0, where);
  r.views_used = json_get_or<int>(j, "views_used", 0, where);
  r.views_dropped = json_get_or<int>(j, "views_dropped", 0, where);
  if (j.contains("std")) {
    const Json& s = j.at("std");
    r.std.fx = json_get<double>(s, "fx", where);
    r.std.fy = json_get<double>(s, "fy", where);
    r.std.cx = json_get<double>(s, "cx", where);
    r.std.cy = json_get<double>(s, "cy", where);
    auto d = json_get<std::vector<double>>(s, "dist", where);
    for (std::size_t i = 0; i < std::min<std::size_t>(5, d.size()); ++i) r.std.dist[i] = d[i];
  }
  if (j.contains("k3")) {
    const Json& k = j.at("k3");
    r.k3.mode = json_get_or<std::string>(k, "mode", "free", where);
    r.k3.fixed = json_get_or<bool>(k, "fixed", false, where);
    r.k3.note = json_get_or<std::string>(k, "note", "", where);
    if (k.contains("free_fit")) {
      r.k3.free_value = json_get<double>(k.at("free_fit"), "k3", where);
      r.k3.free_std = json_get<double>(k.at("free_fit"), "std", where);
    }
  }
  if (j.contains("board")) {
    const Json& b = j.at("board");
    r.board.cols = json_get<int>(b, "cols", where);
    r.board.rows = json_get<int>(b, "rows", where);
    r.board.square_m = json_get<double>(b, "square_m", where);
  }
  if (j.contains("corner_method")) r.corner_method = corner_method_from_string(json_get<std::string>(j, "corner_method", where), where + ": key 'corner_method'");
  r.bit_depth = json_get_or<int>(j, "bit_depth", 8, where);
  r.blur_sigma_px = json_get_or<double>(j, "blur_sigma_px", 0.0, where);
  r.median_corner_std_px = json_get_or<double>(j, "median_corner_std_px", 0.0, where);
  if (j.contains("views")) {
    for (const Json& o : j.at("views")) {
      ViewReport v;
      v.name = json_get<std::string>(o, "name", where);
      v.detected = json_get_or<bool>(o, "detected", false, where);
      v.used = json_get_or<bool>(o, "used", false, where);
      v.reason = json_get_or<std::string>(o, "reason", "", where);
      v.rms_px = json_get_or<double>(o, "rms_px", 0.0, where);
      v.max_px = json_get_or<double>(o, "max_px", 0.0, where);
      v.blur_sigma_px = json_get_or<double>(o, "blur_sigma_px", 0.0, where);
      v.contrast = json_get_or<double>(o, "contrast", 0.0, where);
      v.fallback_corners = json_get_or<int>(o, "fallback_corners", 0, where);
      r.views.push_back(v);
    }
  }
  if (j.contains("provenance")) r.provenance = Provenance::from_json(j.at("provenance"), where);
  return r;
}

void IntrinsicsResult::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

IntrinsicsResult IntrinsicsResult::load(const std::filesystem::path& path) {
  return from_json(read_json_file(path), path.string());
}

CameraModel load_camera_model(const std::filesystem::path& path) {
  return CameraModel::from_json(read_json_file(path), path.string());
}

}  // namespace paintlab::calib
