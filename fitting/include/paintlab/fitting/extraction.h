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
// The pixel geometry is the same for every image (camera and sphere do not move), so a
// SphereSampler computes it once per session; each image then costs one pass over its
// sphere pixels. bin_frames() streams images through a bounded pipeline: images are read
// and extracted in parallel, and binned in input order, so memory stays bounded (a few
// images in flight) and the table is the same whatever the thread count.
#include <cstdint>
#include <filesystem>
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
  void add(const ExtractionStats& o);
  Json to_json() const;
  // "N images: S samples (I invalid, G grazing pixels skipped) in B measured bins"
  std::string describe(std::size_t measured_bins) const;
};

// One HDR image and the table angle it was taken at.
struct HdrFrame {
  std::filesystem::path path;
  double angle_deg = 0.0;
};

class SphereSampler {
 public:
  // Needs camera.json, sphere.json, light.json and scale.json (CalibrationError naming
  // what is missing). width x height: the HDR images' size (must match the camera's).
  SphereSampler(const calib::RigCalibration& calibration, const ExtractionOptions& options = {});

  std::size_t pixel_count() const { return pixels_.size(); }
  int width() const { return width_; }
  int height() const { return height_; }

  // Appends the samples of one HDR image (mono "Y" or "R", "G", "B" channels, with
  // optional "var.*" and "valid"; hdr_merge.h) to `out`. Throws DataError naming `source`
  // when the image size or channels are wrong.
  ExtractionStats extract(const ExrImage& hdr, double table_angle_deg, SampleBatch& out,
                          const std::string& source = "HDR image") const;

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
  std::vector<Pixel> pixels_;
};

// Reads, extracts and bins a list of frames (see above). IoError/DataError name the file.
BinnedTable bin_frames(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                       const ExtractionOptions& extraction, const BinningOptions& binning,
                       ExtractionStats* stats = nullptr);

}  // namespace paintlab::fit
