#pragma once
// Calibration scenes rendered through the simulated camera (same intrinsics, distortion
// and pixel grid as the sphere, so Sensor::expose() turns them into raw frames): a planar
// chessboard or ChArUco board at a pose with sub-pixel accurate edges, a dark frame and a
// uniform field for flat fielding. The white reference sphere is SimWorld::render_with()
// with a brdf::Lambertian paint.
#include <array>
#include <cstdint>
#include <vector>

#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"
#include "paintlab/sim/camera_model.h"

namespace paintlab::sim {

// A printed chessboard. Board frame (OpenCV's object points): origin at the first inner
// corner, x along a row of corners, y down the rows, z = 0 on the board, +z away from the
// side that carries the print.
struct Chessboard {
  int cols = 9;                 // inner corners per row (OpenCV patternSize.width)
  int rows = 6;                 // inner corners per column (patternSize.height)
  double square_m = 0.02;
  double margin_squares = 1.0;  // white border around the outer squares, in squares
  double white_albedo = 0.8;
  double black_albedo = 0.04;

  // Inner corners in the board frame, row by row (x fastest): cv::findChessboardCorners' order.
  std::vector<Vec3> corners() const;
  // The printed area (squares + margin) in the board frame: [lo, hi] in x and y.
  Vec2 outline_lo() const;
  Vec2 outline_hi() const;
  // Albedo at a board point (outside the printed area: -1).
  double albedo(double x, double y) const;
  void check() const;  // DataError naming the bad field
};

// A ChArUco board as OpenCV's aruco::CharucoBoard::create(squares_x, squares_y, square_m,
// marker_m, dictionary) lays it out: board frame origin at the outer corner of square
// (0, 0), x along a row, y down the columns; squares with (x + y) even are black, the
// others carry markers 0, 1, ... in row-major order, centred, each with a one-bit black
// border; ChArUco corner k is inner corner (k % (squares_x - 1) + 1, k / (squares_x - 1) + 1)
// times square_m.
struct CharucoBoard {
  int squares_x = 5;
  int squares_y = 7;
  double square_m = 0.04;
  double marker_m = 0.02;
  int dictionary = 10;         // cv::aruco predefined dictionary (10 = DICT_6X6_250)
  double margin_squares = 0.5; // white border around the squares, in squares
  double white_albedo = 0.8;
  double black_albedo = 0.04;

  std::vector<Vec3> corners() const;  // ChArUco corners by id, board frame
  int marker_count() const;
  void check() const;
};

// A colour chart laid out as X-Rite's ColorChecker Classic: rows x cols square patches with
// black gaps on a black body. Board frame: origin at the top-left corner of the first patch
// (A01), x along a row (A01 -> A06), y down the rows (A -> D), z = 0 on the chart, +z away
// from the print. Patch colours are linear sRGB reflectances (D65), row-major, as a chart
// reference's patches A01, A02, ... D06; a colour outside sRGB has a negative component.
struct ColourChart {
  int cols = 6;
  int rows = 4;
  double patch_m = 0.04;        // side of a patch
  double gap_m = 0.004;         // black between patches
  double border_m = 0.012;      // black body around the patches
  double body_albedo = 0.03;
  std::vector<std::array<double, 3>> patch_rgb;

  Vec2 outline_lo() const;  // the chart body, board frame
  Vec2 outline_hi() const;
  Vec2 patch_centre(int k) const;  // patch k (row-major) in the board frame
  // Reflectance at a board point; -1 in every channel outside the chart.
  std::array<double, 3> albedo(double x, double y) const;
  double max_albedo() const;  // the brightest patch channel
  void check() const;         // DataError naming the bad field
};

// How a planar target is lit: uniformly (radiance = albedo * irradiance / pi, times the
// illuminant's colour per channel) in front of a background of constant radiance.
struct PlaneLighting {
  double irradiance_w_m2 = 1.0;
  double background_radiance = 0.0;
  std::array<double, 3> colour{1.0, 1.0, 1.0};  // the illuminant in scene linear sRGB ((1,1,1) = D65)
};

// Radiance of the chessboard at cam_from_board. Pixels whose footprint crosses an edge
// are supersampled with samples x samples points (the others are uniform), so edges are
// placed with sub-pixel accuracy. channels: 1 or 3 (grey).
ImageF render_chessboard(const CameraModel& camera, const Chessboard& board, const Rigid3& cam_from_board,
                         const PlaneLighting& lighting = {}, int samples = 16, int channels = 1, int threads = 0);

// Radiance of a ChArUco board at cam_from_board (as render_chessboard: supersampled edges,
// the same camera). Marker bits come from OpenCV's dictionary.
ImageF render_charuco(const CameraModel& camera, const CharucoBoard& board, const Rigid3& cam_from_board,
                      const PlaneLighting& lighting = {}, int samples = 16, int channels = 1, int threads = 0);

// Radiance of a colour chart at cam_from_board, three channels (scene linear sRGB).
ImageF render_colour_chart(const CameraModel& camera, const ColourChart& chart, const Rigid3& cam_from_board,
                           const PlaneLighting& lighting = {}, int samples = 16, int threads = 0);

// Pixel positions of board-frame points (cv::projectPoints with the camera's K and dist).
std::vector<Vec2> project_points(const CameraModel& camera, const Rigid3& cam_from_board,
                                 const std::vector<Vec3>& points_board);

// `count` varied poses (tilts up to about 40 deg, boards filling 30-60 % of the width,
// spread over the image) at which the whole printed board is inside the image with a
// margin, facing the camera. Deterministic for a seed. Throws DataError if the board
// cannot fit the image at all.
std::vector<Rigid3> chessboard_poses(const CameraModel& camera, const Chessboard& board, int count,
                                     std::uint64_t seed);
// The same for a ChArUco board (its printed area, squares and margin).
std::vector<Rigid3> charuco_poses(const CameraModel& camera, const CharucoBoard& board, int count,
                                  std::uint64_t seed);

// The same for a colour chart, with milder tilts (at most about 20 deg: a chart is measured
// facing the camera, and a steep one shows the print's gloss).
std::vector<Rigid3> colour_chart_poses(const CameraModel& camera, const ColourChart& chart, int count,
                                       std::uint64_t seed);

// A uniform scene radiance over the whole image (a diffuser in front of the lens: flat field).
ImageF uniform_field(const CameraModel& camera, double radiance, int channels = 1);
// No light at all (lens cap): the sensor pass then gives dark current, read noise, black
// level and hot pixels.
ImageF dark_field(const CameraModel& camera, int channels = 1);

}  // namespace paintlab::sim
