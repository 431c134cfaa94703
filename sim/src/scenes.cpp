#include "paintlab/sim/scenes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <opencv2/aruco.hpp>

#include "paintlab/core/error.h"
#include "parallel.h"
#include "rng.h"

namespace paintlab::sim {

std::vector<Vec3> Chessboard::corners() const {
  std::vector<Vec3> out;
  out.reserve(static_cast<std::size_t>(cols) * rows);
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) out.emplace_back(i * square_m, j * square_m, 0.0);
  return out;
}

Vec2 Chessboard::outline_lo() const { return Vec2::Constant(-(1.0 + margin_squares) * square_m); }

Vec2 Chessboard::outline_hi() const {
  return {(cols + margin_squares) * square_m, (rows + margin_squares) * square_m};
}

double Chessboard::albedo(double x, double y) const {
  Vec2 lo = outline_lo(), hi = outline_hi();
  if (x < lo.x() || y < lo.y() || x > hi.x() || y > hi.y()) return -1.0;
  double u = x / square_m, v = y / square_m;
  if (u < -1.0 || v < -1.0 || u >= cols || v >= rows) return white_albedo;  // the margin
  auto iu = static_cast<long>(std::floor(u)), iv = static_cast<long>(std::floor(v));
  return ((iu + iv) & 1) ? white_albedo : black_albedo;
}

void Chessboard::check() const {
  if (cols < 2 || rows < 2) throw DataError("chessboard: needs at least 2 x 2 inner corners");
  if (!(square_m > 0)) throw DataError("chessboard: square_m must be > 0");
  if (!(margin_squares >= 0)) throw DataError("chessboard: margin_squares must be >= 0");
  if (!(white_albedo >= 0 && black_albedo >= 0 && white_albedo <= 1 && black_albedo <= 1))
    throw DataError("chessboard: albedos must be in [0, 1]");
}

namespace {

// Board coordinates of the ray through normalised (x, y); false when the ray meets the
// board's plane behind the camera. hinv = inverse of [r1 r2 t] (board plane -> normalised).
inline bool board_point(const Mat3& hinv, const Vec2& xn, Vec2* out) {
  Vec3 v = hinv * Vec3(xn.x(), xn.y(), 1.0);
  if (v.z() <= 0) return false;
  *out = v.head<2>() / v.z();
  return true;
}

}  // namespace

namespace {

Eigen::Array3d as_rgb(double grey) { return Eigen::Array3d::Constant(grey); }
Eigen::Array3d as_rgb(const std::array<double, 3>& rgb) { return {rgb[0], rgb[1], rgb[2]}; }

// Renders a printed plane: albedo(p) (grey or RGB; -1 outside the print) and region(p), an id that is
// constant over convex patches of constant albedo, so pixels whose four corners share an
// id are uniform and only the others are supersampled.
template <class Albedo, class Region>
ImageF render_planar(const CameraModel& camera, const Rigid3& cam_from_board, const PlaneLighting& lighting,
                     int samples, int channels, int threads, const Albedo& albedo, const Region& region) {
  if (samples < 1 || samples > 64) throw DataError("planar target: samples must be in [1, 64]");
  if (channels != 1 && channels != 3) throw DataError("planar target: channels must be 1 or 3");
  Mat3 R = cam_from_board.matrix();
  Mat3 h;
  h.col(0) = R.col(0);
  h.col(1) = R.col(1);
  h.col(2) = cam_from_board.translation;
  if (std::abs(h.determinant()) < 1e-15) throw DataError("planar target: the board is seen edge-on");
  Mat3 hinv = h.inverse();
  // The print faces the camera when the board's +z points away from it.
  bool print_faces_camera = R.col(2).dot(cam_from_board.translation) > 0;
  const double scale = lighting.irradiance_w_m2 / kPi;
  const Eigen::Array3d tint(lighting.colour[0], lighting.colour[1], lighting.colour[2]);
  const Eigen::Array3d background = Eigen::Array3d::Constant(lighting.background_radiance);
  auto radiance = [&](bool front, const Vec2& p) -> Eigen::Array3d {
    if (!front) return background;
    const Eigen::Array3d a = as_rgb(albedo(p));
    return a[0] <= -1.0 ? background : Eigen::Array3d(a * scale * tint);
  };
  auto region_of = [&](bool front, const Vec2& p) -> std::int64_t {
    if (!front) return -1;
    if (as_rgb(albedo(p))[0] <= -1.0) return -2;
    return region(p);
  };

  const int w = camera.width(), hgt = camera.height();
  const auto& grid = camera.corner_grid();
  const std::size_t gw = static_cast<std::size_t>(w) + 1;
  ImageF out(w, hgt, channels, 0.0f);
  detail::parallel_rows(hgt, threads, [&](int y) {
    for (int x = 0; x < w; ++x) {
      std::array<std::int64_t, 4> ids;
      Vec2 p;
      for (int k = 0; k < 4; ++k) {
        const Vec2& xn = grid[(static_cast<std::size_t>(y) + (k >> 1)) * gw + x + (k & 1)];
        bool front = print_faces_camera && board_point(hinv, xn, &p);
        ids[k] = region_of(front, p);
      }
      Eigen::Array3d v;
      if (ids[0] == ids[1] && ids[0] == ids[2] && ids[0] == ids[3]) {
        bool front = print_faces_camera && board_point(hinv, camera.grid_point(x, y, 0.5, 0.5), &p);
        v = radiance(front, p);
      } else {
        Eigen::Array3d sum = Eigen::Array3d::Zero();
        for (int b = 0; b < samples; ++b)
          for (int a = 0; a < samples; ++a) {
            bool front = print_faces_camera &&
                         board_point(hinv, camera.grid_point(x, y, (a + 0.5) / samples, (b + 0.5) / samples), &p);
            sum += radiance(front, p);
          }
        v = sum / (samples * samples);
      }
      float* px = &out.at(x, y, 0);
      for (int c = 0; c < channels; ++c) px[c] = static_cast<float>(v[c]);
    }
  });
  camera.blur(out, threads);
  return out;
}

}  // namespace

Vec2 ColourChart::outline_lo() const { return Vec2::Constant(-border_m); }

Vec2 ColourChart::outline_hi() const {
  return {cols * patch_m + (cols - 1) * gap_m + border_m, rows * patch_m + (rows - 1) * gap_m + border_m};
}

Vec2 ColourChart::patch_centre(int k) const {
  const double pitch = patch_m + gap_m;
  return {(k % cols) * pitch + 0.5 * patch_m, (k / cols) * pitch + 0.5 * patch_m};
}

std::array<double, 3> ColourChart::albedo(double x, double y) const {
  const Vec2 lo = outline_lo(), hi = outline_hi();
  if (x < lo.x() || y < lo.y() || x > hi.x() || y > hi.y()) return {-1.0, -1.0, -1.0};
  const double pitch = patch_m + gap_m;
  const double u = x / pitch, v = y / pitch;
  const auto iu = static_cast<long>(std::floor(u)), iv = static_cast<long>(std::floor(v));
  if (iu < 0 || iv < 0 || iu >= cols || iv >= rows || x - iu * pitch >= patch_m || y - iv * pitch >= patch_m)
    return {body_albedo, body_albedo, body_albedo};
  return patch_rgb[static_cast<std::size_t>(iv * cols + iu)];
}

double ColourChart::max_albedo() const {
  double m = body_albedo;
  for (const auto& p : patch_rgb) m = std::max({m, p[0], p[1], p[2]});
  return m;
}

void ColourChart::check() const {
  if (cols < 1 || rows < 1) throw DataError("colour chart: needs at least one row and one column of patches");
  if (patch_rgb.size() != static_cast<std::size_t>(cols * rows))
    throw DataError("colour chart: " + std::to_string(patch_rgb.size()) + " patch colours for " +
                    std::to_string(cols * rows) + " patches");
  if (!(patch_m > 0 && gap_m >= 0 && border_m >= 0)) throw DataError("colour chart: sizes must be > 0");
  if (!(body_albedo >= 0 && body_albedo <= 1)) throw DataError("colour chart: body_albedo must be in [0, 1]");
  for (const auto& p : patch_rgb)
    for (double c : p)
      if (!(c > -0.5 && c <= 1.5))
        throw DataError("colour chart: a patch reflectance component must be in (-0.5, 1.5] (linear sRGB)");
}

ImageF render_colour_chart(const CameraModel& camera, const ColourChart& chart, const Rigid3& cam_from_board,
                           const PlaneLighting& lighting, int samples, int threads) {
  chart.check();
  const double pitch = chart.patch_m + chart.gap_m;
  return render_planar(
      camera, cam_from_board, lighting, samples, 3, threads, [&](const Vec2& p) { return chart.albedo(p.x(), p.y()); },
      [&](const Vec2& p) -> std::int64_t {
        const auto iu = static_cast<std::int64_t>(std::floor(p.x() / pitch));
        const auto iv = static_cast<std::int64_t>(std::floor(p.y() / pitch));
        const bool in_patch = iu >= 0 && iv >= 0 && iu < chart.cols && iv < chart.rows &&
                              p.x() - iu * pitch < chart.patch_m && p.y() - iv * pitch < chart.patch_m;
        return in_patch ? iv * chart.cols + iu : -3;
      });
}

ImageF render_chessboard(const CameraModel& camera, const Chessboard& board, const Rigid3& cam_from_board,
                         const PlaneLighting& lighting, int samples, int channels, int threads) {
  board.check();
  return render_planar(
      camera, cam_from_board, lighting, samples, channels, threads,
      [&](const Vec2& p) { return board.albedo(p.x(), p.y()); },
      [&](const Vec2& p) {
        // Which square (the margin continues the grid of squares).
        auto iu = static_cast<std::int64_t>(std::floor(p.x() / board.square_m));
        auto iv = static_cast<std::int64_t>(std::floor(p.y() / board.square_m));
        bool margin = p.x() < -board.square_m || p.y() < -board.square_m || p.x() >= board.cols * board.square_m ||
                      p.y() >= board.rows * board.square_m;
        return ((iv + 1024) * 4096 + (iu + 1024)) * 2 + (margin ? 1 : 0);
      });
}

std::vector<Vec3> CharucoBoard::corners() const {
  std::vector<Vec3> out;
  for (int y = 1; y < squares_y; ++y)
    for (int x = 1; x < squares_x; ++x) out.emplace_back(x * square_m, y * square_m, 0.0);
  return out;
}

int CharucoBoard::marker_count() const { return squares_x * squares_y / 2; }

void CharucoBoard::check() const {
  if (squares_x < 2 || squares_y < 2) throw DataError("charuco: needs at least 2 x 2 squares");
  if (!(square_m > 0) || !(marker_m > 0) || !(marker_m < square_m))
    throw DataError("charuco: needs 0 < marker_m < square_m");
  if (!(margin_squares >= 0)) throw DataError("charuco: margin_squares must be >= 0");
  if (!(white_albedo >= 0 && black_albedo >= 0 && white_albedo <= 1 && black_albedo <= 1))
    throw DataError("charuco: albedos must be in [0, 1]");
}

ImageF render_charuco(const CameraModel& camera, const CharucoBoard& board, const Rigid3& cam_from_board,
                      const PlaneLighting& lighting, int samples, int channels, int threads) {
  board.check();
  cv::Ptr<cv::aruco::Dictionary> dict;
  try {
    dict = cv::aruco::getPredefinedDictionary(board.dictionary);
  } catch (const cv::Exception&) {
    throw DataError("charuco: unknown predefined dictionary " + std::to_string(board.dictionary));
  }
  // Marker ids of the squares (-1: black square) and each marker's bits with its border,
  // one byte per bit (OpenCV draws it at one pixel per bit: 255 white).
  const int cells = dict->markerSize + 2;
  std::vector<int> id_of(static_cast<std::size_t>(board.squares_x * board.squares_y), -1);
  std::vector<cv::Mat> bits;
  for (int y = 0; y < board.squares_y; ++y)
    for (int x = 0; x < board.squares_x; ++x) {
      if ((x + y) % 2 == 0) continue;
      int id = static_cast<int>(bits.size());
      if (id >= dict->bytesList.rows)
        throw DataError("charuco: the board needs more markers than the dictionary has (" +
                        std::to_string(dict->bytesList.rows) + ")");
      cv::Mat img;
      dict->drawMarker(id, cells, img, 1);
      bits.push_back(img);
      id_of[static_cast<std::size_t>(y * board.squares_x + x)] = id;
    }
  const double sq = board.square_m, inset = 0.5 * (board.square_m - board.marker_m);
  const double cell = board.marker_m / cells;
  const double lo = -board.margin_squares * sq;
  const double hi_x = (board.squares_x + board.margin_squares) * sq, hi_y = (board.squares_y + board.margin_squares) * sq;
  // Square (ix, iy) and, inside a marker, the bit (r, c); r = c = -1 elsewhere.
  struct Where {
    long ix, iy, r, c;
    bool inside;
  };
  auto where = [&](const Vec2& p) {
    Where w{static_cast<long>(std::floor(p.x() / sq)), static_cast<long>(std::floor(p.y() / sq)), -1, -1, false};
    w.inside = w.ix >= 0 && w.iy >= 0 && w.ix < board.squares_x && w.iy < board.squares_y;
    if (w.inside && id_of[static_cast<std::size_t>(w.iy * board.squares_x + w.ix)] >= 0) {
      double u = (p.x() - w.ix * sq - inset) / cell, v = (p.y() - w.iy * sq - inset) / cell;
      if (u >= 0 && v >= 0 && u < cells && v < cells) {
        w.c = static_cast<long>(u);
        w.r = static_cast<long>(v);
      }
    }
    return w;
  };
  return render_planar(
      camera, cam_from_board, lighting, samples, channels, threads,
      [&](const Vec2& p) {
        if (p.x() < lo || p.y() < lo || p.x() > hi_x || p.y() > hi_y) return -1.0;
        Where w = where(p);
        if (!w.inside) return board.white_albedo;  // the margin
        int id = id_of[static_cast<std::size_t>(w.iy * board.squares_x + w.ix)];
        if (id < 0) return board.black_albedo;
        if (w.r < 0) return board.white_albedo;
        return bits[static_cast<std::size_t>(id)].at<std::uint8_t>(static_cast<int>(w.r), static_cast<int>(w.c)) > 127
                   ? board.white_albedo
                   : board.black_albedo;
      },
      [&](const Vec2& p) {
        Where w = where(p);
        std::int64_t square = (w.iy + 1024) * 4096 + (w.ix + 1024);
        return (square * 64 + (w.r + 1)) * 64 + (w.c + 1) + (w.inside ? 0 : (std::int64_t{1} << 50));
      });
}

std::vector<Vec2> project_points(const CameraModel& camera, const Rigid3& cam_from_board,
                                 const std::vector<Vec3>& points_board) {
  std::vector<Vec2> out;
  out.reserve(points_board.size());
  for (const Vec3& p : points_board) out.push_back(camera.project(cam_from_board * p));
  return out;
}

namespace {

// Poses of a planar target whose printed area is [lo, hi] (board frame, z = 0); `what`
// names the target in the error.
std::vector<Rigid3> planar_poses(const CameraModel& camera, const Vec2& lo, const Vec2& hi, int count,
                                 std::uint64_t seed, const std::string& what, double max_tilt_deg = 40.0) {
  if (count < 1) return {};
  const auto& t = camera.truth();
  const double w = camera.width(), h = camera.height();
  const double board_w = hi.x() - lo.x();
  const Vec3 centre_board(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0.0);
  const double margin_px = 0.02 * std::min(w, h);
  std::uint64_t counter = 0;
  auto uniform = [&](double a, double b) {
    return a + (b - a) * detail::uniform01(detail::hash_key(seed, 0x504f'5345 /* "POSE" */, counter++));
  };
  auto fits = [&](const Rigid3& pose) {
    Vec3 n = pose.rotation * Vec3::UnitZ();
    if (n.dot(pose * centre_board) <= 0) return false;  // print must face the camera
    for (int k = 0; k < 4; ++k) {
      Vec3 q((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), 0.0);
      Vec3 pc = pose * q;
      if (pc.z() <= 0.05 * pose.translation.z()) return false;
      Vec2 px = camera.project(pc);
      if (px.x() < margin_px || px.y() < margin_px || px.x() > w - 1 - margin_px || px.y() > h - 1 - margin_px)
        return false;
      // Stay where the distortion model is monotone: compare with the undistorted position.
      Vec2 xn(pc.x() / pc.z(), pc.y() / pc.z());
      if ((camera.unproject(px) - xn).norm() > 1e-6) return false;
    }
    return true;
  };

  std::vector<Rigid3> poses;
  for (int k = 0; k < count; ++k) {
    bool found = false;
    for (int attempt = 0; attempt < 2000 && !found; ++attempt) {
      // Later attempts use smaller boards and milder tilts.
      double shrink = 1.0 - 0.4 * std::min(1.0, attempt / 1000.0);
      double fill = uniform(0.3, 0.6) * shrink;
      double distance = t.fx_px * board_w / (fill * w);
      double tilt = deg_to_rad(max_tilt_deg) * shrink;
      double ax = uniform(-tilt, tilt), ay = uniform(-tilt, tilt), roll = uniform(-deg_to_rad(20), deg_to_rad(20));
      // Spread the board centres over a 3 x 3 grid of image regions.
      int cell = k % 9;
      double u = (0.5 + (cell % 3)) / 3.0 * w + uniform(-0.12, 0.12) * w;
      double v = (0.5 + (cell / 3)) / 3.0 * h + uniform(-0.12, 0.12) * h;
      Vec3 ray = camera.ray_cam(Vec2(u, v));
      Rigid3 pose;
      pose.rotation = Eigen::AngleAxisd(ax, Vec3::UnitX()) * Eigen::AngleAxisd(ay, Vec3::UnitY()) *
                      Eigen::AngleAxisd(roll, Vec3::UnitZ());
      pose.translation = ray * (distance / ray.z()) - pose.rotation * centre_board;
      if (fits(pose)) {
        poses.push_back(pose);
        found = true;
      }
    }
    if (!found)
      throw DataError(what + " does not fit the " + std::to_string(camera.width()) + "x" +
                      std::to_string(camera.height()) + " image at any tried pose");
  }
  return poses;
}

}  // namespace

std::vector<Rigid3> chessboard_poses(const CameraModel& camera, const Chessboard& board, int count,
                                     std::uint64_t seed) {
  board.check();
  return planar_poses(camera, board.outline_lo(), board.outline_hi(), count, seed,
                      "chessboard_poses: a " + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                          " board");
}

std::vector<Rigid3> charuco_poses(const CameraModel& camera, const CharucoBoard& board, int count,
                                  std::uint64_t seed) {
  board.check();
  const Vec2 lo = Vec2::Constant(-board.margin_squares * board.square_m);
  const Vec2 hi((board.squares_x + board.margin_squares) * board.square_m,
                (board.squares_y + board.margin_squares) * board.square_m);
  return planar_poses(camera, lo, hi, count, seed,
                      "charuco_poses: a " + std::to_string(board.squares_x) + "x" +
                          std::to_string(board.squares_y) + " ChArUco board");
}

std::vector<Rigid3> colour_chart_poses(const CameraModel& camera, const ColourChart& chart, int count,
                                       std::uint64_t seed) {
  chart.check();
  return planar_poses(camera, chart.outline_lo(), chart.outline_hi(), count, seed,
                      "colour_chart_poses: a " + std::to_string(chart.cols) + "x" + std::to_string(chart.rows) +
                          " colour chart",
                      20.0);
}

ImageF uniform_field(const CameraModel& camera, double radiance, int channels) {
  if (channels != 1 && channels != 3) throw DataError("uniform field: channels must be 1 or 3");
  if (!(radiance >= 0)) throw DataError("uniform field: radiance must be >= 0");
  return ImageF(camera.width(), camera.height(), channels, static_cast<float>(radiance));
}

ImageF dark_field(const CameraModel& camera, int channels) { return uniform_field(camera, 0.0, channels); }

}  // namespace paintlab::sim
