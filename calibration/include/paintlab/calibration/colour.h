#pragma once
// Colour characterisation: the map from the camera's linear RGB to CIE XYZ and linear sRGB
// (D65), fitted on a colour chart of known colours, with the CIEDE2000 it leaves per patch.
// Written as calib/colour.json.
//
// Reference values come from a CGATS (IT8.7) file: Debian's argyll-ref installs the
// ColorChecker 24's (kColorCheckerReference: L*a*b* under D50), or the technician gives the
// certificate of their own chart. The values are adapted to D65 (Bradford, lcms) before the
// fit, because linear sRGB and everything downstream of the colour calibration are D65.
//
// Models (Finlayson, Mackiewicz and Hurlbert, "Color Correction Using Root-Polynomial
// Regression", IEEE TIP 24(5), 2015):
// - matrix: XYZ = M rgb, M 3x3 (9 unknowns; at least 9 usable patches).
// - root-polynomial-2: XYZ = M [r, g, b, sqrt(rg), sqrt(gb), sqrt(rb)], M 3x6.
// - root-polynomial-3: adds the cube roots of r g^2, g b^2, r b^2, g r^2, b g^2, b r^2 and
//   r g b: M 3x13. Every term has degree one, so the map is exposure-invariant: k rgb goes
//   to k XYZ, as a plain polynomial would not.
// M is fitted in two stages: linear least squares on XYZ (every usable patch weighted by
// 1/Y, so dark patches count in proportion to how the eye sees differences), then the mean
// of dE00^2 over the patches minimised by Ceres from that start (as Imatest's CCM fits do).
//
// Scale: the chart's illumination and the exposure are unknown, so M maps the chart's camera
// values to XYZ with Y = 1 for a perfect white diffuser under the same light. `camera_white`
// is the camera value that perfect white gives; `to_xyz_balanced` takes values already
// divided by it per channel (the white-balanced values the per-channel radiometric
// calibration yields on the white reference sphere), so that (1, 1, 1) is D65 white.
#include <array>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "paintlab/calibration/record.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

inline constexpr const char* kColorCheckerReference = "/usr/share/color/argyll/ref/ColorChecker.cie";
inline constexpr const char* kColourFile = "colour.json";

// The colours of a chart's patches, as its reference file gives them.
struct ChartReference {
  std::string source;                 // the file read
  std::vector<std::string> patches;   // SAMPLE_ID, in the file's order
  std::vector<colour::Lab> lab;       // under `white`
  colour::Xyz white = colour::d50();  // the white the values are relative to

  // Each patch's XYZ adapted to D65 (Bradford), Y = 1 for the perfect white diffuser.
  std::vector<colour::Xyz> xyz_d65() const;
  std::vector<colour::Lab> lab_d65() const;
  // As linear sRGB reflectances (a colour outside sRGB has a negative component).
  std::vector<std::array<double, 3>> srgb_reflectances() const;
  int index_of(const std::string& patch) const;  // -1 when the chart has no such patch

  // A CGATS file with SAMPLE_ID and either LAB_L LAB_A LAB_B or XYZ_X XYZ_Y XYZ_Z (0..100).
  // IoError for an unreadable file; DataError naming the file and the line (the CGATS
  // parser's), or the patch and field, for anything else.
  static ChartReference load(const std::filesystem::path& path, const colour::Xyz& white = colour::d50());
};

enum class ColourModel { Matrix, RootPolynomial2, RootPolynomial3 };
const char* to_string(ColourModel model);
ColourModel colour_model_from_string(const std::string& name, const std::string& where);
int colour_model_terms(ColourModel model);  // 3, 6, 13
// The model's terms of a camera value (negative channels count as 0 under the roots).
Eigen::VectorXd colour_terms(ColourModel model, const colour::Rgb& rgb);

// What the camera recorded of one patch: the mean linear value per channel (dark-subtracted,
// response-linearised, any consistent unit), its standard error, and whether any of its
// pixels clipped.
struct PatchMeasurement {
  std::string name;  // the reference's SAMPLE_ID
  colour::Rgb rgb = colour::Rgb::Zero();
  colour::Rgb stderr_rgb = colour::Rgb::Zero();
  long long pixels = 0;
  bool clipped = false;
};

struct ColourFitOptions {
  ColourModel model = ColourModel::Matrix;
  bool refine_de00 = true;      // minimise mean dE00^2 after the linear start
  double min_signal_rel = 1e-3;  // patches darker than this share of the brightest are not used
  void check() const;
};

struct PatchReport {
  std::string name;
  colour::Lab reference;  // D65
  colour::Lab fitted;     // D65, the model applied to the measurement
  double de00 = 0.0;
  bool used = false;
  std::string why_not;    // when not used: "clipped", "too dark", "not measured"
};

struct ColourCalibration {
  ColourModel model = ColourModel::Matrix;
  Eigen::MatrixXd matrix;  // 3 x colour_model_terms(model): camera terms -> XYZ (D65)
  colour::Rgb camera_white = colour::Rgb::Ones();  // the camera value of a perfect white diffuser
  int patches_used = 0;
  double mean_de00 = 0.0, median_de00 = 0.0, max_de00 = 0.0;
  std::string worst_patch;
  std::vector<PatchReport> patches;
  std::string reference;  // the reference file
  Provenance provenance;

  colour::Xyz to_xyz(const colour::Rgb& camera) const;
  colour::Rgb to_srgb(const colour::Rgb& camera) const { return colour::xyz_to_srgb(to_xyz(camera)); }
  // Camera values divided per channel by camera_white: (1, 1, 1) is D65 white.
  colour::Xyz to_xyz_balanced(const colour::Rgb& balanced) const { return to_xyz(balanced.cwiseProduct(camera_white)); }
  colour::Rgb to_srgb_balanced(const colour::Rgb& balanced) const {
    return colour::xyz_to_srgb(to_xyz_balanced(balanced));
  }
  // The matrix model as one linear map from balanced camera values to linear sRGB (D65):
  // xyz_to_srgb M diag(camera_white). Unset for the root polynomials, which are not linear.
  std::optional<Eigen::Matrix3d> balanced_srgb_matrix() const;

  // The model, the patches used, mean/median/max dE00 and the worst patch, in one line.
  std::string describe() const;
  Json to_json() const;
  static ColourCalibration from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;
  static ColourCalibration load(const std::filesystem::path& path);
};

// Where a ColorChecker 24 is in an image and what each patch recorded. The corners are those
// of the patch area (the patches plus a tenth of a patch), next to A01, A06, D06 and D01.
struct ChartDetection {
  std::array<Eigen::Vector2d, 4> corners;
  std::vector<Eigen::Vector2d> centres;  // per patch, the reference's order
  double pitch_px = 0.0;                 // patch-to-patch distance at the chart's centre
  double orientation_margin = 0.0;       // how much worse the next best orientation fits (>= 3)
  std::vector<PatchMeasurement> patches;
};

// Finds a ColorChecker 24 (4 rows x 6 patches; `reference` holds its 24 patches row by row,
// A01 .. D06) in a linear RGB image (dark-subtracted, linearised; any scale) and measures each
// patch over its central square (a fifth of the patch's area, outliers beyond 4 MADs of the
// patch's median left out), its values at or above `saturation` counted as clipped. The chart
// is found by OpenCV's Macbeth chart detector (opencv_contrib mcc) on a tone-mapped copy; its
// orientation is then chosen among the four the grid allows as the one whose patches an affine
// colour map fits best. CalibrationError when no chart is found, when it is too small (a
// pitch under 24 px) or when no orientation fits clearly better than another.
ChartDetection find_colour_chart(const ImageF& linear_rgb, const ChartReference& reference,
                                 double saturation = std::numeric_limits<double>::infinity());

// Fits the model to the measured patches (matched to the reference by name). Throws
// CalibrationError when fewer usable patches remain than the model needs (the model's terms plus
// six: 9 for the matrix, 12 and 19 for the root polynomials), naming how many were clipped or dark.
ColourCalibration fit_colour(const ChartReference& reference, const std::vector<PatchMeasurement>& measured,
                             const ColourFitOptions& options);

}  // namespace paintlab::calib
