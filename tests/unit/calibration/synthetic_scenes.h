#pragma once
// Synthetic calibration images for the calibration tests, independent of the models the
// calibration code fits: a hard-edged chessboard integrated over each pixel (supersampled
// where an edge crosses the pixel), projected through OpenCV's camera model, then blurred
// (Gaussian PSF), with Gaussian noise and quantised.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/chessboard.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"

namespace paintlab::calib::testing {

struct ChessboardScene {
  CameraModel camera;
  BoardSpec board;
  double white = 0.85;          // fraction of full scale
  double black = 0.08;
  double background = 0.4;      // outside the printed board
  int margin_squares = 1;       // white border beyond the outer squares, in squares
  double blur_sigma_px = 0.8;   // optics PSF
  double noise_rel = 0.004;     // Gaussian noise std, fraction of full scale
  int bit_depth = 16;
  int supersample = 4;          // per axis, in fine cells that an edge crosses
  double gradient = 0.15;       // illumination falls linearly by this fraction across the image
};

// Board-plane coordinates (metres) of the ray through normalised coordinates `n`, or false
// when the ray misses the plane (parallel or behind the camera).
inline bool board_point(const Rigid3& cam_from_board, const Vec2& n, Vec2* xy) {
  const Mat3 R = cam_from_board.matrix();
  const Vec3 d(n.x(), n.y(), 1.0);
  const Vec3 normal = R.col(2);
  const double denom = normal.dot(d);
  if (std::abs(denom) < 1e-12) return false;
  const double s = normal.dot(cam_from_board.translation) / denom;
  if (s <= 0) return false;
  const Vec3 p = R.transpose() * (s * d - cam_from_board.translation);
  *xy = p.head<2>();
  return true;
}

inline double board_value(const ChessboardScene& sc, const Vec2& xy) {
  const double sq = sc.board.square_m;
  const double X = xy.x() / sq, Y = xy.y() / sq;  // in squares; inner corners at integers
  const double m = sc.margin_squares;
  if (X < -1.0 - m || X > sc.board.cols + m || Y < -1.0 - m || Y > sc.board.rows + m) return sc.background;
  if (X < -1.0 || X > sc.board.cols || Y < -1.0 || Y > sc.board.rows) return sc.white;
  const long ix = static_cast<long>(std::floor(X)), iy = static_cast<long>(std::floor(Y));
  return ((ix + iy) & 1) ? sc.black : sc.white;
}

// Distance (in squares) from the nearest square edge, to decide where to supersample.
inline double edge_distance(const ChessboardScene& sc, const Vec2& xy) {
  const double X = xy.x() / sc.board.square_m, Y = xy.y() / sc.board.square_m;
  return std::min(std::abs(X - std::round(X)), std::abs(Y - std::round(Y)));
}

// Undistorted normalised coordinates of the centres of a grid `oversample` times finer
// than the pixels (one extra column), computed once per camera and shared by all views.
struct NormalizedMap {
  int oversample = 1;
  int width = 0;
  std::vector<Vec2> xy;
  NormalizedMap(const CameraModel& cam, int oversample_)
      : oversample(oversample_), width(cam.width_px * oversample_ + 1) {
    const int height = cam.height_px * oversample;
    xy.resize(static_cast<std::size_t>(width) * height);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) xy[static_cast<std::size_t>(y) * width + x] = cam.normalized(pixel(x, y));
  }
  // Pixel coordinates of the centre of fine cell (x, y).
  Vec2 pixel(double x, double y) const {
    return {(x + 0.5) / oversample - 0.5, (y + 0.5) / oversample - 0.5};
  }
  const Vec2& at(int x, int y) const { return xy[static_cast<std::size_t>(y) * width + x]; }
  // Bilinear interpolation between the cell centres at fine-grid coordinates (fx, fy)
  // (linear extrapolation past the last row): the lens mapping is smooth, so over a third
  // of a pixel this differs from undistorting by ~1e-5 px, at a fraction of the cost.
  Vec2 interpolate(double fx, double fy) const {
    const int rows = static_cast<int>(xy.size()) / width;
    const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, width - 2);
    const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, rows - 2);
    const double u = fx - i, v = fy - j;
    return (1.0 - v) * ((1.0 - u) * at(i, j) + u * at(i + 1, j)) + v * ((1.0 - u) * at(i, j + 1) + u * at(i + 1, j + 1));
  }
};

// Renders on the fine grid (supersampling cells that an edge crosses), blurs there with the
// optics PSF and averages blocks down to pixels: the blur acts before the pixel samples,
// as in a camera (blurring pixel samples instead would make edges lock to the pixel grid).
inline Image<std::uint16_t> render_chessboard(const ChessboardScene& sc, const Rigid3& cam_from_board,
                                              std::uint64_t seed, const NormalizedMap* map = nullptr) {
  const CameraModel& cam = sc.camera;
  const int w = cam.width_px, h = cam.height_px;
  std::unique_ptr<NormalizedMap> own;
  if (!map) {
    own = std::make_unique<NormalizedMap>(cam, 3);
    map = own.get();
  }
  const int m = map->oversample;
  cv::Mat f(h * m, w * m, CV_64F);
  for (int y = 0; y < h * m; ++y)
    for (int x = 0; x < w * m; ++x) {
      Vec2 xy;
      double v = sc.background;
      if (board_point(cam_from_board, map->at(x, y), &xy)) {
        // Size of one cell on the board, in squares (finite difference).
        Vec2 xy1;
        double cell_in_squares = 1.0;
        if (board_point(cam_from_board, map->at(x + 1, y), &xy1))
          cell_in_squares = (xy1 - xy).norm() / sc.board.square_m;
        if (edge_distance(sc, xy) > 1.5 * cell_in_squares) {
          v = board_value(sc, xy);
        } else {
          // n x n samples in a multi-jittered pattern: every sample has its own x and its
          // own y (n^2 distinct offsets per axis), so an edge parallel to the pixel grid
          // is not quantised to 1/n of a cell.
          double sum = 0;
          const int n = sc.supersample;
          for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
              const Vec2 q = map->interpolate(x - 0.5 + (i + (j + 0.5) / n) / n, y - 0.5 + (j + (i + 0.5) / n) / n);
              Vec2 b;
              sum += board_point(cam_from_board, q, &b) ? board_value(sc, b) : sc.background;
            }
          v = sum / (n * n);
        }
      }
      const double light = 1.0 - sc.gradient * (map->pixel(x, y).x() / w);
      f.at<double>(y, x) = v * light;
    }
  if (sc.blur_sigma_px > 0)
    cv::GaussianBlur(f, f, cv::Size(0, 0), sc.blur_sigma_px * m, sc.blur_sigma_px * m, cv::BORDER_REPLICATE);
  cv::Mat px;
  cv::resize(f, px, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sc.noise_rel);
  const double full = static_cast<double>((1u << sc.bit_depth) - 1u);
  Image<std::uint16_t> img(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = (px.at<double>(y, x) + noise(rng)) * full;
      img.at(x, y) = static_cast<std::uint16_t>(std::clamp(std::lround(v), 0L, static_cast<long>(full)));
    }
  return img;
}

// True corner positions (pixels) of the board seen with this pose.
inline std::vector<Vec2> true_corners(const CameraModel& cam, const BoardSpec& board, const Rigid3& cam_from_board) {
  std::vector<Vec2> out;
  for (const Vec3& p : board.object_points()) out.push_back(cam.project(cam_from_board * p));
  return out;
}

// A pose that shows the board (centre at `centre_cam`) tilted by (tilt_x_deg, tilt_y_deg)
// about its own axes and rolled by roll_deg, facing the camera.
inline Rigid3 board_pose(const BoardSpec& board, const Vec3& centre_cam, double tilt_x_deg, double tilt_y_deg,
                         double roll_deg) {
  Eigen::Matrix3d R = (Eigen::AngleAxisd(deg_to_rad(roll_deg), Vec3::UnitZ()) *
                       Eigen::AngleAxisd(deg_to_rad(tilt_y_deg), Vec3::UnitY()) *
                       Eigen::AngleAxisd(deg_to_rad(tilt_x_deg), Vec3::UnitX()))
                          .toRotationMatrix();
  const Vec3 half(0.5 * (board.cols - 1) * board.square_m, 0.5 * (board.rows - 1) * board.square_m, 0.0);
  Rigid3 t;
  t.rotation = Eigen::Quaterniond(R);
  t.translation = centre_cam - R * half;
  return t;
}

}  // namespace paintlab::calib::testing
