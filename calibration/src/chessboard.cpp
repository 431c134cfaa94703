#include "paintlab/calibration/chessboard.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "cv_util.h"
#include "paintlab/calibration/cost_functions.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "dense_solve.h"

namespace paintlab::calib {

BoardSpec BoardSpec::parse(const std::string& size, double square_mm, const std::string& option) {
  BoardSpec b;
  std::istringstream in(size);
  char x = 0;
  std::string rest;
  if (!(in >> b.cols >> x) || (x != 'x' && x != 'X') || !(in >> b.rows) || (in >> rest))
    throw UsageError(option + " '" + size + "': expected COLSxROWS of inner corners, e.g. 9x6");
  b.square_m = square_mm * 1e-3;
  b.check();
  return b;
}

std::vector<Vec3> BoardSpec::object_points() const {
  std::vector<Vec3> out;
  out.reserve(static_cast<std::size_t>(corner_count()));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out.emplace_back(c * square_m, r * square_m, 0.0);
  return out;
}

void BoardSpec::check() const {
  if (cols < 3 || rows < 3)
    throw UsageError("board: at least 3x3 inner corners are needed (got " + std::to_string(cols) + "x" +
                     std::to_string(rows) + ")");
  if (cols == rows)
    throw UsageError("board: a square pattern (" + std::to_string(cols) + "x" + std::to_string(rows) +
                     ") is ambiguous under rotation; use one with different inner-corner counts");
  if (!(square_m > 0.0) || !std::isfinite(square_m))
    throw UsageError("board: square size must be > 0 mm (got " + std::to_string(square_m * 1e3) + ")");
}

constexpr EnumNames<CornerMethod, 2> kCornerMethodNames{
    {{CornerMethod::SaddleFit, "saddle-fit"}, {CornerMethod::OpenCvSubPix, "opencv-subpix"}}};

const char* to_string(CornerMethod m) { return enum_name(kCornerMethodNames, m); }

CornerMethod corner_method_from_string(const std::string& s, std::string_view where) {
  return enum_from_name(kCornerMethodNames, s, "corner method", where);
}

void CornerOptions::check() const {
  if (subpix_half_window_px < 0 || subpix_half_window_px > 50)
    throw OptionError("CornerOptions::subpix_half_window_px", std::to_string(subpix_half_window_px), "0..50");
  if (!(window_frac > 0.1 && window_frac <= 0.7))
    throw OptionError("CornerOptions::window_frac", fmt::format("{}", window_frac), "(0.1, 0.7]");
  if (min_half_window_px < 2 || min_half_window_px > max_half_window_px)
    throw OptionError("CornerOptions::min_half_window_px", std::to_string(min_half_window_px),
                      "2..max_half_window_px (" + std::to_string(max_half_window_px) + ")");
  if (max_half_window_px > 60)
    throw OptionError("CornerOptions::max_half_window_px", std::to_string(max_half_window_px), "min_half_window_px..60");
}

SaddleCost::SaddleCost(const SaddleWindow* w) : w_(w) {
  set_num_residuals(static_cast<int>(w->values.size()));
  mutable_parameter_block_sizes()->push_back(kParams);
}

ceres::CostFunction* SaddleCost::Create(const SaddleWindow* window) { return new SaddleCost(window); }

bool SaddleCost::Evaluate(double const* const* parameters, double* r, double** jacobians) const {
  const double* x = parameters[0];
  double* J = jacobians ? jacobians[0] : nullptr;
  const double s = std::exp(x[4]) * M_SQRT2;
  if (!std::isfinite(s) || !(s > 0)) return false;
  const double inv_s = 1.0 / s;
  const double c1 = std::cos(x[2]), s1 = std::sin(x[2]);
  const double c2 = std::cos(x[3]), s2 = std::sin(x[3]);
  const double n1x = -s1, n1y = c1, n2x = -s2, n2y = c2;
  constexpr double k2_sqrtpi = 1.1283791670955126;  // 2 / sqrt(pi)
  const int side = 2 * w_->h + 1;
  for (int j = 0; j < side; ++j) {
    const double dy = (j - w_->h) - x[1];
    for (int i = 0; i < side; ++i) {
      const int k = j * side + i;
      const double dx = (i - w_->h) - x[0];
      const double z1 = (n1x * dx + n1y * dy) * inv_s;
      const double z2 = (n2x * dx + n2y * dy) * inv_s;
      const double e1 = std::erf(z1), e2 = std::erf(z2);
      const double P = e1 * e2;
      const double B = x[6] + x[10] * dx + x[11] * dy;
      r[k] = x[5] + x[8] * dx + x[9] * dy + B * P + x[7] * P * P - w_->values[static_cast<std::size_t>(k)];
      if (!J) continue;
      // dE_k/dz_k, then P's derivatives through z_k = d_k / s.
      const double g1 = k2_sqrtpi * std::exp(-z1 * z1), g2 = k2_sqrtpi * std::exp(-z2 * z2);
      const double a1 = e2 * g1 * inv_s, a2 = e1 * g2 * inv_s;  // dP/dd_1, dP/dd_2
      const double dPdx = -(a1 * n1x + a2 * n2x);
      const double dPdy = -(a1 * n1y + a2 * n2y);
      const double dPdt1 = a1 * (-c1 * dx - s1 * dy);
      const double dPdt2 = a2 * (-c2 * dx - s2 * dy);
      const double dPdls = -(e2 * g1 * z1 + e1 * g2 * z2);
      const double dIdP = B + 2.0 * x[7] * P;
      double* row = J + static_cast<std::size_t>(k) * kParams;
      row[0] = -x[8] - x[10] * P + dIdP * dPdx;
      row[1] = -x[9] - x[11] * P + dIdP * dPdy;
      row[2] = dIdP * dPdt1;
      row[3] = dIdP * dPdt2;
      row[4] = dIdP * dPdls;
      row[5] = 1.0;
      row[6] = P;
      row[7] = P * P;
      row[8] = dx;
      row[9] = dy;
      row[10] = dx * P;
      row[11] = dy * P;
    }
  }
  return true;
}

namespace {

using Window = SaddleWindow;
constexpr int kParams = SaddleCost::kParams;

bool load_window(const cv::Mat& img, int cx, int cy, int h, Window* w) {
  if (cx - h < 0 || cy - h < 0 || cx + h >= img.cols || cy + h >= img.rows) return false;
  w->cx = cx;
  w->cy = cy;
  w->h = h;
  w->values.resize(static_cast<std::size_t>((2 * h + 1) * (2 * h + 1)));
  std::size_t k = 0;
  for (int y = cy - h; y <= cy + h; ++y) {
    const float* row = img.ptr<float>(y);
    for (int x = cx - h; x <= cx + h; ++x) w->values[k++] = row[x];
  }
  return true;
}

struct SaddleResult {
  bool ok = false;
  Vec2 corner = Vec2::Zero();
  double std_px = 0.0;
  double sigma_px = 0.0;
  double contrast = 0.0;
};

// Fits the model in the window centred at the pixel nearest `start`; edge directions
// theta1, theta2 start from the board's row and column directions.
SaddleResult fit_saddle(const cv::Mat& img, const Vec2& start, double theta1, double theta2, int h,
                        const double* warm = nullptr) {
  SaddleResult out;
  Window w;
  const int cx = static_cast<int>(std::lround(start.x())), cy = static_cast<int>(std::lround(start.y()));
  if (!load_window(img, cx, cy, h, &w)) return out;
  double p[kParams];
  if (warm) {
    std::copy(warm, warm + kParams, p);
  } else {
    p[0] = start.x() - cx;
    p[1] = start.y() - cy;
    p[2] = theta1;
    p[3] = theta2;
    p[4] = 0.0;
    // a, b by linear least squares for the starting shape.
    double s1 = 0, sP = 0, sPP = 0, sI = 0, sPI = 0;
    const int side = 2 * h + 1;
    for (int j = 0; j < side; ++j)
      for (int i = 0; i < side; ++i) {
        const double dx = i - h - p[0], dy = j - h - p[1];
        const double d1 = -std::sin(theta1) * dx + std::cos(theta1) * dy;
        const double d2 = -std::sin(theta2) * dx + std::cos(theta2) * dy;
        const double P = std::erf(d1 / M_SQRT2) * std::erf(d2 / M_SQRT2);
        const double I = w.values[static_cast<std::size_t>(j * side + i)];
        s1 += 1;
        sP += P;
        sPP += P * P;
        sI += I;
        sPI += P * I;
      }
    const double det = s1 * sPP - sP * sP;
    if (!(std::abs(det) > 1e-12)) return out;
    p[5] = (sPP * sI - sP * sPI) / det;
    p[6] = (s1 * sPI - sP * sI) / det;
    p[7] = p[8] = p[9] = p[10] = p[11] = 0.0;
  }
  const int n = static_cast<int>(w.values.size());
  auto* cost = SaddleCost::Create(&w);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  std::unique_ptr<ceres::CostFunction> owned(cost);
  ceres::Problem problem(po);
  problem.AddResidualBlock(cost, nullptr, p);
  const ceres::Solver::Summary summary = solve_dense(problem, 60, 1e-12, 1e-10, 1e-14);
  if (summary.termination_type == ceres::FAILURE) return out;

  const double sigma = std::exp(p[4]);
  Vec2 corner(cx + p[0], cy + p[1]);
  if (!std::isfinite(corner.x()) || !std::isfinite(corner.y())) return out;
  if ((corner - start).norm() > std::max(1.5, 0.5 * h)) return out;
  if (!(sigma > 0.05 && sigma < h)) return out;

  // Covariance of (x, y): s^2 (J^T J)^-1 with s^2 the residual variance.
  std::vector<double> res(static_cast<std::size_t>(n));
  std::vector<double> jac(static_cast<std::size_t>(n) * kParams);
  const double* params[1] = {p};
  double* jacs[1] = {jac.data()};
  if (!cost->Evaluate(params, res.data(), jacs)) return out;
  using JMat = Eigen::Matrix<double, Eigen::Dynamic, kParams, Eigen::RowMajor>;
  using PMat = Eigen::Matrix<double, kParams, kParams>;
  Eigen::Map<JMat> J(jac.data(), n, kParams);
  double rss = 0;
  for (double v : res) rss += v * v;
  const double s2 = rss / std::max(1, n - kParams);
  PMat JtJ = J.transpose() * J;
  PMat cov = JtJ.ldlt().solve(PMat::Identity()) * s2;
  if (!(cov(0, 0) >= 0 && cov(1, 1) >= 0)) return out;
  const double contrast = 2.0 * std::abs(p[6]);
  if (!(contrast > 6.0 * std::sqrt(s2))) return out;  // no pattern here: noise only

  out.ok = true;
  out.corner = corner;
  out.std_px = std::sqrt(0.5 * (cov(0, 0) + cov(1, 1)));
  out.sigma_px = sigma;
  out.contrast = contrast;
  // A second pass with the window centred on the fitted corner keeps the window symmetric
  // about the corner (the model's small errors for oblique edges then cancel).
  if (!warm && (std::lround(corner.x()) != cx || std::lround(corner.y()) != cy)) {
    double q[kParams];
    std::copy(p, p + kParams, q);
    const int ncx = static_cast<int>(std::lround(corner.x())), ncy = static_cast<int>(std::lround(corner.y()));
    q[0] = corner.x() - ncx;
    q[1] = corner.y() - ncy;
    SaddleResult again = fit_saddle(img, corner, p[2], p[3], h, q);
    if (again.ok) return again;
  }
  return out;
}

}  // namespace

ChessboardDetection detect_chessboard(const Image<std::uint16_t>& image, int bit_depth, const BoardSpec& board,
                                      const CornerOptions& options) {
  detail::check_image(image, bit_depth, "chessboard image");
  board.check();
  options.check();
  ChessboardDetection det;
  // A square needs a few pixels to be found at all (OpenCV's detectors assert on images
  // smaller than their filters), in either orientation of the board.
  const int small_side = std::min(image.width(), image.height()), large_side = std::max(image.width(), image.height());
  if (small_side < 3 * (std::min(board.cols, board.rows) + 1) || large_side < 3 * (std::max(board.cols, board.rows) + 1)) {
    det.reason = fmt::format("the image ({}x{} px) is too small to hold a {}x{} chessboard", image.width(),
                             image.height(), board.cols, board.rows);
    return det;
  }
  cv::Mat img = detail::to_unit_float(image, bit_depth);
  cv::Mat img8 = detail::to_detection_u8(img);
  const cv::Size pattern(board.cols, board.rows);
  std::vector<cv::Point2f> pts;
  bool found = false;
  try {
    found = cv::findChessboardCorners(img8, pattern, pts, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) {
      pts.clear();
      found = cv::findChessboardCornersSB(img8, pattern, pts, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE);
    }
  } catch (const cv::Exception& e) {
    det.reason = std::string("OpenCV could not search the image for a chessboard: ") + e.what();
    return det;
  }
  if (!found || static_cast<int>(pts.size()) != board.corner_count()) {
    det.reason = "no " + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                 " chessboard found (whole board visible, in focus, not over-exposed?)";
    return det;
  }

  // Local square size of each corner: distance to its nearest grid neighbour.
  const int n = board.corner_count();
  auto at = [&](int r, int c) { return Vec2(pts[static_cast<std::size_t>(r * board.cols + c)].x,
                                            pts[static_cast<std::size_t>(r * board.cols + c)].y); };
  std::vector<double> spacing(static_cast<std::size_t>(n));
  std::vector<Vec2> ex(static_cast<std::size_t>(n)), ey(static_cast<std::size_t>(n));
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c) {
      const std::size_t k = static_cast<std::size_t>(r * board.cols + c);
      Vec2 q = at(r, c);
      ex[k] = c + 1 < board.cols ? Vec2(at(r, c + 1) - q) : Vec2(q - at(r, c - 1));
      ey[k] = r + 1 < board.rows ? Vec2(at(r + 1, c) - q) : Vec2(q - at(r - 1, c));
      double s = std::numeric_limits<double>::infinity();
      if (c > 0) s = std::min(s, (q - at(r, c - 1)).norm());
      if (c + 1 < board.cols) s = std::min(s, (q - at(r, c + 1)).norm());
      if (r > 0) s = std::min(s, (q - at(r - 1, c)).norm());
      if (r + 1 < board.rows) s = std::min(s, (q - at(r + 1, c)).norm());
      spacing[k] = s;
    }
  const double min_spacing = *std::min_element(spacing.begin(), spacing.end());
  if (!(min_spacing >= 6.0)) {
    det.reason = "squares too small in the image (" + std::to_string(min_spacing) + " px; at least 6 px needed)";
    return det;
  }

  // cornerSubPix with one window for the whole view (as OpenCV does).
  int hw = options.subpix_half_window_px;
  if (hw == 0) hw = std::clamp(static_cast<int>(std::lround(0.25 * min_spacing)), 2, 10);
  cv::cornerSubPix(img, pts, cv::Size(hw, hw), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.0001));

  det.corners_px.resize(static_cast<std::size_t>(n));
  det.corner_std_px.assign(static_cast<std::size_t>(n), std::numeric_limits<double>::quiet_NaN());
  for (int k = 0; k < n; ++k) det.corners_px[static_cast<std::size_t>(k)] = Vec2(pts[static_cast<std::size_t>(k)].x, pts[static_cast<std::size_t>(k)].y);
  if (options.method == CornerMethod::OpenCvSubPix) {
    det.found = true;
    return det;
  }

  // The corners are independent: fitted in parallel, collected in order.
  std::vector<SaddleResult> fits(static_cast<std::size_t>(n));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, fits.size(), 4), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const int h = std::clamp(static_cast<int>(std::floor(options.window_frac * spacing[i])),
                               options.min_half_window_px, options.max_half_window_px);
      fits[i] = fit_saddle(img, det.corners_px[i], std::atan2(ex[i].y(), ex[i].x()), std::atan2(ey[i].y(), ey[i].x()), h);
    }
  });
  std::vector<double> sigmas, contrasts;
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const SaddleResult& f = fits[i];
    if (!f.ok) {
      ++det.fallback;
      continue;
    }
    ++det.fitted;
    det.corners_px[i] = f.corner;
    det.corner_std_px[i] = f.std_px;
    sigmas.push_back(f.sigma_px);
    contrasts.push_back(f.contrast);
  }
  det.blur_sigma_px = upper_median(sigmas);
  det.contrast = upper_median(contrasts);
  det.found = true;
  return det;
}

}  // namespace paintlab::calib
