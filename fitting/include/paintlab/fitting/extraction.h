#pragma once
// BRDF samples from the HDR images of a session (docs/fitting.md "Extraction"). For every
// sphere pixel of the upper half (rig z up), at least `margin_px` inside the silhouette:
// the calibrated sphere gives the point and normal, wo points to the camera centre, wi to
// the calibrated LED position at the image's table angle; the BRDF is
//   f = rate / (scale * E),  E = LED profile * cos(theta_i) / d^2   (calib::LightModel)
// with rate the HDR value (linear DN/s) and scale the absolute calibration
// (calib::ScaleCalibration), and its variance (VarianceModel) in the same units. Pixels the
// merge marked invalid (saturated in every exposure, below the noise floor, hot), non-finite
// values, and directions closer than min_cos to the horizon are skipped and counted.
//
// Lens blur (docs/fitting.md "Lens blur"): the optics spread every pixel's light over its
// neighbours with a Gaussian of sigma = the calibrated highlight blur (light.json), which
// broadens the clear coat's highlight and spills it into dark pixels beside it. Where the
// spill is significant the value is sharpened to first order, I - (sigma^2 / 2) lap(I)
// (5-point Laplacian; the variance propagated); where that correction is a large part of
// the value (structure as small as the blur, where the expansion no longer holds: a
// highlight a few pixels across, a glint) the pixel is kept as measured, and counted.
//
// The pixel geometry is the same for every image (camera and sphere do not move), so a
// SphereSampler computes it once per session; each image then costs one pass over its
// sphere pixels. bin_frames() streams images through a bounded pipeline: images are read
// and extracted in parallel, and binned in input order, so memory stays bounded (a few
// images in flight) and the table is the same whatever the thread count.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/binning.h"

namespace paintlab::fit {

// Where a sample's variance comes from (docs/fitting.md "Noise"): Local = second
// differences of the BRDF with the neighbouring pixels of the same image (pixel noise AND
// flake sparkle, which the HDR variance does not know about), falling back to the HDR
// variance where a neighbour is missing; Hdr = the HDR merge's variance channel alone.
enum class VarianceModel { Local, Hdr };
const char* to_string(VarianceModel v);
// "local" or "hdr"; DataError naming `where` (the flag or file field) for other names.
VarianceModel variance_model_from_string(std::string_view s, std::string_view where);

struct ExtractionOptions {
  double margin_px = 3.0;       // distance from the silhouette (pixels), >= 0
  double min_cos = 0.02;        // n.wi and n.wo at least this (directions off the horizon), [0, 1)
  double min_normal_up = 0.0;   // the "upper half": rig-frame z of the normal above this, [-1, 1)
  VarianceModel variance = VarianceModel::Hdr;
  // Gaussian sigma of the lens blur to undo (pixels): 0 = no correction (the default), < 0 =
  // the calibration's highlight blur (light.json; none when it has none). Opt-in: on a
  // half-resolution rig the highlight blur overstates the optics' (0.35 px for 0.25) and the
  // correction then overshoots the clear coat's peak (docs/fitting.md).
  double blur_sigma_px = 0.0;
  // A pixel whose blur correction exceeds this fraction of its corrected value by more
  // than three standard deviations of the correction is kept as measured (the first-order
  // correction errs by about half the square of the fraction there), (0, 1].
  double max_blur_correction = 0.1;
  // Leave such pixels out instead (counted as blurred): right for paints without sparkle,
  // whose highlight's far flanks then no longer widen the clear coat; wrong with flakes,
  // whose glints (structure as small as the blur) are part of the BRDF's average.
  bool skip_too_sharp = false;
  // A pixel is used only when every pixel within this many pixels (a square) is valid in
  // the HDR image: next to pixels below the noise floor a valid pixel is a censored one
  // (only the ones noise lifted over the floor are there: biased bright), next to saturated
  // ones it holds their spill. [0, 10]; 0: only the pixel itself.
  int valid_margin_px = 2;
  // Colour-filter-array sites (docs/fitting.md "Fitting a Bayer camera at its sites"): of a
  // demosaiced image, keep at every pixel only the colour its filter measured, in camera
  // RGB (the stored linear sRGB through the inverse of the colour calibration's matrix), and
  // bin each colour's sites into a table of its own (bin_frames_by_site): no value that
  // demosaicing interpolated reaches the fit. Needs the 3x3 matrix colour model for sRGB
  // sessions. The lens-blur correction takes its Laplacian over the nearest sites of the
  // pixel's own colour (two pixels away for red and blue, the diagonal greens for green);
  // not with the local variance model (it compares a pixel with its four neighbours, which
  // are other colours here).
  bool cfa_sites = false;
  int threads = 0;              // bin_frames(): 0 = all cores
  int images_in_flight = 0;     // bin_frames(): 0 = 2 x threads
  void check() const;           // DataError naming the first violated rule
};

// What extraction did with the pixels.
struct ExtractionStats {
  std::uint64_t images = 0;
  std::uint64_t sphere_pixels = 0;   // pixels looked at (per image, summed)
  std::uint64_t samples = 0;         // samples produced
  std::uint64_t invalid = 0;         // the HDR merge's valid = 0 (saturated, dark, hot)
  std::uint64_t non_finite = 0;
  std::uint64_t grazing = 0;         // n.wi or n.wo below min_cos, or unlit
  std::uint64_t near_invalid = 0;    // a pixel within valid_margin_px invalid
  std::uint64_t blurred = 0;         // next to a pixel that may be saturated; too sharp with skip_too_sharp
  std::uint64_t deblurred = 0;       // samples whose value the blur correction changed
  std::uint64_t unresolved = 0;      // samples kept as measured: the correction would not hold
  void add(const ExtractionStats& o);
  Json to_json() const;
  // "N images: S samples (I invalid, G grazing, V next to invalid, L blurred pixels skipped;
  // D sharpened, U too sharp to correct) in B measured bins"
  std::string describe(std::size_t measured_bins) const;
};

// One HDR image and the table angle it was taken at.
struct HdrFrame {
  std::filesystem::path path;
  double angle_deg = 0.0;
};

// The lens blur's sigma that extraction corrects (pixels; 0: none): the option when it is
// >= 0, else the light calibration's highlight blur.
double blur_sigma_to_correct(const ExtractionOptions& options, const calib::RigCalibration& calibration);

class SphereSampler {
 public:
  // Needs camera.json, sphere.json, light.json and scale.json (CalibrationError naming
  // what is missing). width x height: the HDR images' size (must match the camera's).
  SphereSampler(const calib::RigCalibration& calibration, const ExtractionOptions& options = {});

  std::size_t pixel_count() const { return pixels_.size(); }
  int width() const { return width_; }
  int height() const { return height_; }
  // The blur sigma corrected (pixels; 0: none), resolved from the options and calibration.
  double blur_sigma_px() const { return blur_sigma_px_; }

  // Appends the samples of one HDR image (mono "Y" or "R", "G", "B" channels, with
  // optional "var.*" and "valid"; hdr_merge.h) to `out`. Throws DataError naming `source`
  // when the image size or channels are wrong.
  ExtractionStats extract(const ExrImage& hdr, double table_angle_deg, SampleBatch& out,
                          const std::string& source = "HDR image") const;
  // With ExtractionOptions::cfa_sites: the samples of a demosaiced colour image, each pixel's
  // own colour only (camera RGB, 1/sr: the value in all three channels of the sample) into
  // `out[c]` for a site of colour c. DataError naming `source` for an image without the
  // paintlab.cfa attribute (not from a Bayer camera) or in sRGB without a matrix colour
  // calibration to invert.
  ExtractionStats extract_sites(const ExrImage& hdr, double table_angle_deg, std::array<SampleBatch, 3>& out,
                                const std::string& source = "HDR image") const;
  // One usable sphere pixel of an image (flake extraction, flakes.h): `pixel` its index in
  // [0, pixel_count()) (the same pixel in every image), wi and wo in its shading frame (z the
  // normal), h_cam their half vector in the camera frame, the BRDF (1/sr) and its variance.
  struct PixelValue {
    std::uint32_t pixel;
    Vec3 wi, wo, h_cam;
    std::array<double, 3> rgb, var;
  };
  // Calls f for every pixel extract() would take (the same rules for invalid, non-finite,
  // grazing and near-invalid pixels), but as measured: no lens-blur correction, the HDR
  // variance (a glint is the structure both would smooth). f is called from several threads
  // at once. Returns the counts; DataError naming `source` as extract().
  ExtractionStats for_each_value(const ExrImage& hdr, double table_angle_deg,
                                 const std::function<void(const PixelValue&)>& f,
                                 const std::string& source = "HDR image") const;
  // cfa_sites: the linear map from the camera RGB of the site tables to the linear sRGB of
  // the session (the colour calibration's balanced matrix times the white balance), with
  // which a model fitted at the sites becomes the paint; unset without a matrix colour
  // calibration (then only camera-RGB sessions can be read at their sites).
  const std::optional<Eigen::Matrix3d>& site_to_srgb() const { return site_to_srgb_; }

 private:
  struct Pixel {
    std::uint32_t index;  // y * width + x
    Eigen::Vector3f point;
    Eigen::Vector3f normal;
    Eigen::Vector3f to_camera;
  };
  const calib::RigCalibration* cal_;
  ExtractionOptions options_;
  int width_ = 0, height_ = 0;
  double blur_sigma_px_ = 0.0;
  std::vector<Pixel> pixels_;
  std::optional<Eigen::Matrix3d> site_to_srgb_;

  ExtractionStats extract_into(const ExrImage& hdr, double table_angle_deg, SampleBatch* out,
                               std::array<SampleBatch, 3>* sites, const std::string& source) const;
};

// Reads, extracts and bins a list of frames (see above). IoError/DataError name the file.
BinnedTable bin_frames(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                       const ExtractionOptions& extraction, const BinningOptions& binning,
                       ExtractionStats* stats = nullptr);

// Frames taken with one calibration: one session's, when several sessions of a paint (other
// spheres or orientations of the sample) are binned into one table (session_binning.h
// bin_sessions). Each group is extracted with its own calibration, and every sample goes
// into the same bins, in group order then frame order (reproducible whatever the threads).
struct CalibratedFrames {
  std::vector<HdrFrame> frames;
  const calib::RigCalibration* calibration = nullptr;
  ExtractionStats* stats = nullptr;  // optional: this group's counts
};
BinnedTable bin_frames(const std::vector<CalibratedFrames>& groups, const ExtractionOptions& extraction,
                       const BinningOptions& binning, ExtractionStats* stats = nullptr);

// The frames of a colour session binned at their colour-filter-array sites
// (ExtractionOptions::cfa_sites, which this sets): one table per camera colour (R, G, B),
// each holding in all three channels the values of that colour's sites, and the map from
// camera RGB to the session's colour space (identity for camera-RGB sessions).
struct SiteTables {
  std::array<BinnedTable, 3> tables;
  Eigen::Matrix3d to_colour_space = Eigen::Matrix3d::Identity();
};
SiteTables bin_frames_by_site(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                              ExtractionOptions extraction, const BinningOptions& binning,
                              ExtractionStats* stats = nullptr);
// The groups' frames by site into the same three tables: DataError when two groups' colours
// map to the colour space differently (a site's camera RGB would mean two colours).
SiteTables bin_frames_by_site(const std::vector<CalibratedFrames>& groups, ExtractionOptions extraction,
                              const BinningOptions& binning, ExtractionStats* stats = nullptr);

}  // namespace paintlab::fit
