#pragma once
// Camera intrinsics from chessboard views: K and the 5-coefficient Brown-Conrady distortion
// (OpenCV's calibrateCamera, extended form: parameter standard deviations and per-view
// errors), with outlier views named and dropped with a reason. Written as calib/camera.json
// ("K" 3x3 row-major, "dist" in OpenCV order, "rms_px", "image_size" -- DESIGN.md contract).
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/chessboard.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

// One chessboard photo: raw values with bit_depth significant bits (8..16).
struct BoardImage {
  std::string name;  // file name or capture label; errors and reports use it
  Image<std::uint16_t> pixels;
  int bit_depth = 8;
};

// Corners already found in one view (row-major, BoardSpec::cols per row).
struct CornerView {
  std::string name;
  std::vector<Vec2> corners_px;
  double blur_sigma_px = 0.0;  // from detection (0 when unknown)
  double contrast = 0.0;
};

struct IntrinsicsOptions {
  CornerOptions corners;
  // A view is an outlier when its reprojection RMS exceeds both outlier_factor x the median
  // view RMS and outlier_min_px; the worst one is dropped and the camera re-solved until none is.
  double outlier_factor = 3.0;
  double outlier_min_px = 0.5;
  // A view whose corner fits failed for more than this fraction of its corners is dropped.
  double max_fallback_frac = 0.25;
  int min_views = 3;             // fewer usable views: CalibrationError
  double initial_focal_px = 0;   // > 0: start from this focal length (narrow lenses), else OpenCV's guess
  // Keep k3 = 0: over a narrow field of view k3 r^6 is unobservable and only trades with the
  // principal point and k2 (the file still holds five coefficients).
  bool fix_k3 = false;
  // Decide k3 from the data (ignored when fix_k3 is set): solve with k3 free and, unless
  // |k3| exceeds k3_significance standard deviations (k3 told apart from 0), solve again with
  // k3 = 0: a narrow field of view, or views that do not reach the image's corners, leave it
  // undetermined, trading with k2 and the principal point. The result says which
  // (IntrinsicsResult::k3). 3 rather than 1: the simulated 19 mm CLI test rig (true k3 = 0)
  // gives k3 = -238 +- 102 free.
  bool auto_fix_k3 = false;
  double k3_significance = 3.0;

  void check() const;  // UsageError naming the first violated rule
};

struct ViewReport {
  std::string name;
  bool detected = false;
  bool used = false;
  std::string reason;      // why the view was dropped (empty when used)
  double rms_px = 0.0;     // reprojection RMS against the final camera (dropped views: own pose)
  double max_px = 0.0;     // largest corner residual
  double blur_sigma_px = 0.0;
  double contrast = 0.0;
  int fallback_corners = 0;
  std::vector<Vec2> corners_px;
  // Per corner: the detected position minus the final camera's projection (camera.json
  // "residuals_px", for the residual plots of `paintlab report`); empty when not detected.
  std::vector<Vec2> residuals_px;
  Rigid3 cam_from_board;   // pose of the board (valid when detected)
};

// 1-sigma standard deviations of the intrinsic parameters (OpenCV's estimate).
struct IntrinsicsStd {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> dist{};
};

// How k3 was treated, and why.
struct K3Decision {
  std::string mode = "free";   // "free", "fixed" (asked for) or "auto" (IntrinsicsOptions::auto_fix_k3)
  bool fixed = false;          // k3 held at 0 in the result
  // Auto: the free solution's k3 and its standard deviation (NaN otherwise).
  double free_value = std::numeric_limits<double>::quiet_NaN();
  double free_std = std::numeric_limits<double>::quiet_NaN();
  std::string note;            // one line for the technician (empty for "free")
};

struct IntrinsicsResult {
  CameraModel camera;
  K3Decision k3;
  IntrinsicsStd std;
  double rms_px = 0.0;           // over every corner of every used view
  double worst_px = 0.0;         // largest corner residual among used views
  int views_used = 0;
  int views_dropped = 0;
  std::vector<ViewReport> views;  // every input view, in input order
  BoardSpec board;
  CornerMethod corner_method = CornerMethod::SaddleFit;
  int bit_depth = 8;
  double blur_sigma_px = 0.0;    // median over used views (focus figure)
  double median_corner_std_px = 0.0;  // corner localisation uncertainty from the fits
  Provenance provenance;

  // What the technician reads after the step (several lines, no trailing newline): views used,
  // RMS and worst corner, the intrinsics with their standard deviations, the k3 decision, the
  // views dropped and why.
  std::string describe() const;
  Json to_json() const;
  static IntrinsicsResult from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;           // atomic
  static IntrinsicsResult load(const std::filesystem::path& path);  // IoError / DataError naming the file
};

// Detects the board in every image, calibrates, drops outliers. Throws CalibrationError
// when fewer than options.min_views views remain (the message names the dropped views and
// why), DataError when the images differ in size.
IntrinsicsResult calibrate_intrinsics(const std::vector<BoardImage>& images, const BoardSpec& board,
                                      const IntrinsicsOptions& options = {});

// The same from corners already detected (views that were not detected have no corners
// and are reported as dropped).
IntrinsicsResult calibrate_from_corners(const std::vector<CornerView>& views, const BoardSpec& board, int width_px,
                                        int height_px, const IntrinsicsOptions& options = {});

// Loads only the camera model of a camera.json (any file with K, dist, image_size).
CameraModel load_camera_model(const std::filesystem::path& path);

}  // namespace paintlab::calib
