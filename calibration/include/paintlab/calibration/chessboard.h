#pragma once
// Chessboard corners with sub-pixel accuracy, from 8- to 16-bit images.
//
// Detection uses OpenCV (findChessboardCorners, then findChessboardCornersSB as a fallback)
// on an 8-bit copy; localisation works on the full-precision image. Each inner corner is
// refined by fitting a local model of the checker pattern to the pixel values around it
// ("saddle fit"): two straight edges through the corner at free angles, the pattern
// sign(d1) sign(d2) blurred by an isotropic Gaussian, so the blurred value is
// erf(d1 / (sqrt2 sigma)) erf(d2 / (sqrt2 sigma)) (exact for perpendicular edges; for
// oblique ones the error is point-symmetric about the corner and does not shift it), times
// a contrast, plus a quadratic term for a non-linear response and a linear illumination
// gradient. The fit also yields each corner's standard deviation (from the residuals) and
// the blur of the optics (sigma), a focus figure.
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"

namespace paintlab::calib {

// A planar chessboard: cols x rows INNER corners (OpenCV's pattern size), squares of
// square_m. Board frame: origin at the first inner corner, x along a row, z = 0.
struct BoardSpec {
  int cols = 0;
  int rows = 0;
  double square_m = 0.0;

  // "9x6" and the square side in mm; UsageError naming `option` on a malformed value.
  static BoardSpec parse(const std::string& size, double square_mm, const std::string& option = "--board");
  int corner_count() const { return cols * rows; }
  // Row-major (cols per row), z = 0, metres.
  std::vector<Vec3> object_points() const;
  void check() const;  // UsageError naming the first violated rule
};

enum class CornerMethod {
  SaddleFit,     // the local checker-model fit described above (default)
  OpenCvSubPix,  // cv::cornerSubPix only (OpenCV's own procedure, for comparison)
};
const char* to_string(CornerMethod m);
CornerMethod corner_method_from_string(const std::string& s, std::string_view where = {});  // DataError naming the value

struct CornerOptions {
  CornerMethod method = CornerMethod::SaddleFit;
  // cv::cornerSubPix half window (OpenCV's winSize). 0: automatic, a quarter of the local
  // square size (clamped to 2..10 px). OpenCV's sample uses 11 (a 23x23 window).
  int subpix_half_window_px = 0;
  // Saddle fit half window: window_frac x the local square size (distance to the nearest
  // neighbouring corner), clamped to [min_half_window_px, max_half_window_px].
  double window_frac = 0.45;
  int min_half_window_px = 3;
  int max_half_window_px = 15;

  void check() const;  // UsageError naming the first violated rule
};

struct ChessboardDetection {
  bool found = false;
  std::string reason;               // why no board was found (empty when found)
  std::vector<Vec2> corners_px;     // row-major, cols per row; OpenCV pixel coordinates
  std::vector<double> corner_std_px;  // 1-sigma localisation uncertainty of each corner, per axis
  int fitted = 0;                   // corners refined by the saddle fit
  int fallback = 0;                 // corners whose fit failed (kept at the cornerSubPix position)
  double blur_sigma_px = std::numeric_limits<double>::quiet_NaN();  // median Gaussian blur
  double contrast = std::numeric_limits<double>::quiet_NaN();       // median white - black, / full scale
};

// Finds the board in `image` (bit_depth significant bits, 8..16; 1 channel, or 3 averaged).
ChessboardDetection detect_chessboard(const Image<std::uint16_t>& image, int bit_depth, const BoardSpec& board,
                                      const CornerOptions& options = {});

}  // namespace paintlab::calib
