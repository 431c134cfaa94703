#pragma once
// Flake statistics of a session (docs/sparkle.md). The smooth fitted model is the flakes'
// average; what a pixel shows above it is sparkle. For every usable sphere pixel of every
// HDR image (the samples extraction sees, extraction.h) the measured BRDF is compared with
// the model's at the pixel's directions; a pixel glints where its excess over the model is
// above both `threshold_sigma` standard deviations of the HDR merge's noise (with the
// model's relative error `model_error` added to it) and `threshold_ratio` times the model.
//
// The statistics are kept per slice of the refracted directions (the AxF car-paint
// model's flake BTF layout, models.md): ibar and obar, wi and wo refracted by the clear coat
// (index `ior`), hbar their half vector; theta_F = angle(hbar, n), theta_I = angle(hbar,
// ibar); slice (f, i) with f = floor(num_theta_f * 2 theta_F / pi), i likewise for theta_I
// (the SDK's convention, without Unity's +0.5). Per slice:
//  - the sparkle area: glinting pixels / pixels looked at;
//  - the glint intensity: the excess over the model relative to the model (luminance; the
//    contrast), its mean and quantiles;
//  - the glint colours in CIELAB, of the contrast colour (f - m) / Y(m) (its Y is the
//    contrast: L* 100 at a contrast of 1), which carries over to any geometry of the slice
//    by multiplying with the model's luminance there: an octree over the slice's colour box reduced to at most
//    `clusters` leaves (Golla and Klein 2017), each a cuboid (the box of its colours) with
//    its mean and probability, and an inverse-CDF table of `cdf_steps` cluster indices;
//  - the glint lifetime: a run of n consecutive light positions in which a pixel glints is
//    a chord of length n d through a flake's cone of half-angle delta (d: the pixel's half-
//    vector step between positions, in air); chords across a cone at random offsets average
//    pi delta / 2, so delta = (2 / pi) mean(n d).
// Instrument-style numbers (sparkle area and intensity under directional light at 15, 45
// and 75 deg, viewed along the normal) come from the pixels whose geometry is within
// `instrument_tolerance_deg` of that (docs/sparkle.md "Instrument numbers").
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/brdf.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/extraction.h"

namespace paintlab::fit {

// The slices' bin index (flakes.json options.bin_convention, the AxF-like /flake_btf's
// attribute bin_convention).
inline constexpr const char* kFlakeBinConvention = "floor(num * 2 theta / pi), no +0.5";

struct FlakeOptions {
  double ior = 1.5;              // the clear coat's, for the refracted directions, [1, 3]
  int num_theta_f = 12;          // slices over theta_F in [0, 90) deg, [1, 64]
  int num_theta_i = 12;          // and over theta_I; num_theta_f * num_theta_i < 256 (8-bit LUT)
  double threshold_sigma = 5.0;  // a glint's excess: at least this many standard deviations, > 0
  double threshold_ratio = 0.5;  // and at least this part of the model, > 0
  double model_error = 0.05;     // the model's relative error added to the noise, >= 0
  int clusters = 50;             // colour clusters per slice, [1, 255]
  int cdf_steps = 500;           // inverse-CDF entries per slice, [2, 100000]
  int min_glints = 20;           // slices with fewer glints get no colour clusters, >= 1
  double instrument_tolerance_deg = 5.0;  // (0, 30]
  int threads = 0;               // 0 = all cores
  void check() const;            // DataError naming the first violated rule
  bool operator==(const FlakeOptions&) const = default;
};

// One colour cluster: the box of its colours, their mean, its probability in the slice.
struct FlakeCluster {
  colour::Lab lo, hi, mean;
  double probability = 0.0;
  std::uint64_t count = 0;
  bool operator==(const FlakeCluster&) const = default;
};

struct FlakeSlice {
  int theta_f = 0, theta_i = 0;      // bin indices
  std::uint64_t pixels = 0;          // pixel samples looked at
  std::uint64_t glints = 0;
  double area() const { return pixels ? static_cast<double>(glints) / static_cast<double>(pixels) : 0.0; }
  double intensity_mean = 0.0;       // mean contrast (excess / model, luminance) of the glints
  double glint_model_y = 0.0;        // mean luminance Y (1/sr) of the smooth model at the glints
  std::array<double, 5> intensity_quantiles{};  // 10, 25, 50, 75, 90 %
  std::vector<FlakeCluster> clusters;           // probabilities sum to 1; empty below min_glints
  std::vector<std::uint8_t> inverse_cdf;        // cdf_steps cluster indices
  std::uint64_t runs = 0;            // glint runs whose middle falls in the slice
  double lifetime_deg = 0.0;         // from those runs (0 without)
  bool operator==(const FlakeSlice&) const = default;
};

// Sparkle area and intensity at an instrument geometry.
struct InstrumentSparkle {
  double illumination_deg = 0.0;
  std::uint64_t pixels = 0;          // pixel samples within the tolerance
  std::uint64_t glints = 0;
  double area_percent = 0.0;         // glints / pixels x 100
  double intensity = 0.0;            // mean contrast of those glints
  bool measured() const { return pixels > 0; }
  bool operator==(const InstrumentSparkle&) const = default;
};

struct FlakeStats {
  FlakeOptions options;
  std::string colour_space;          // of the session's values (colour::kLinearSrgb, kCameraRgb)
  bool mono = false;                 // a monochrome session: colours are L* only
  std::uint64_t images = 0;
  std::uint64_t pixels = 0;          // pixel samples compared with the model
  std::uint64_t glints = 0;
  std::uint64_t runs = 0;
  double lifetime_deg = 0.0;         // of all runs
  double step_deg = 0.0;             // median half-vector step between consecutive positions
  std::vector<FlakeSlice> slices;    // theta_i-major; only slices with pixels
  std::vector<InstrumentSparkle> instrument;  // at 15, 45, 75 deg
  double area() const { return pixels ? static_cast<double>(glints) / static_cast<double>(pixels) : 0.0; }
  // No glint anywhere: a paint without flakes (nothing to export).
  bool empty() const { return glints == 0; }
  const FlakeSlice* slice(int theta_f, int theta_i) const;
  bool operator==(const FlakeStats&) const = default;
};

// The flakes as the AxF car-paint model's flake BTF (CPA2 as renderers read it, models.md):
// slices of RGB textures, theta_I-major: slice_lut[i] is the first slice of theta_I bin i
// and slice_lut[i + 1] its limit, so theta_I bin i holds theta_F bins 0 .. slice_lut[i + 1]
// - slice_lut[i] - 1; bins at or past max_theta_i read zero (the flakes have died off). Bin
// index floor(num * 2 theta / pi) for both angles (the SDK's; Unity adds 0.5). A texel
// holds the BRDF (1/sr) a flake adds there: at a glinting texel a colour drawn from the
// slice's clusters (inverse CDF, then uniform in the cluster's CIELAB box, back to linear
// RGB over pi), elsewhere 0; a texel glints with the slice's sparkle area. slice_mean is each
// slice's mean texel: the smooth model already holds the flakes' average, so a renderer that
// adds the BTF to this paint's model adds (BTF - slice_mean) to keep it (docs/sparkle.md).
struct FlakeBtf {
  int num_theta_f = 0, num_theta_i = 0, max_theta_i = 0;
  int texture_size = 0;            // texels a side
  double ior = 1.5;                // the refraction the slices are in
  std::vector<int> slice_lut;      // max_theta_i + 1 entries, non-decreasing, from 0
  std::vector<double> texels;      // slices x size x size x 3 (row-major)
  std::vector<double> slice_mean;  // slices x 3
  int slices() const { return slice_lut.empty() ? 0 : slice_lut.back(); }
  // The slice of bins (f, i), or -1 where the BTF reads zero.
  int slice_of(int theta_f_bin, int theta_i_bin) const;
  const double* texel(int slice, int x, int y) const {
    return texels.data() + ((static_cast<std::size_t>(slice) * texture_size + static_cast<std::size_t>(y)) *
                                texture_size + static_cast<std::size_t>(x)) * 3;
  }
  // DataError naming `where` and what is inconsistent (LUT order, sizes, negative texels).
  void check(const std::string& where) const;
  bool operator==(const FlakeBtf&) const = default;
};

// The BTF of measured statistics (empty stats: no slices, slice_lut all zero). The
// textures are drawn from a random stream seeded by `seed` and the slice, so the same
// statistics give the same file.
FlakeBtf make_flake_btf(const FlakeStats& stats, int texture_size = 32, std::uint64_t seed = 1);

// The slice indices of refracted directions (theta_F, theta_I from wi, wo in the shading
// frame, z the normal): {f, i}, each in [0, num).
std::array<int, 2> flake_slice_of(const Vec3& wi, const Vec3& wo, double ior, int num_theta_f, int num_theta_i);

// Octree colour reduction of a slice's glint colours to at most `clusters` leaves, and the
// inverse CDF of their probabilities (FlakeSlice::clusters, inverse_cdf).
void cluster_flake_colours(const std::vector<colour::Lab>& colours, int clusters, int cdf_steps,
                           std::vector<FlakeCluster>* out, std::vector<std::uint8_t>* inverse_cdf);

// The statistics of `frames` (in sweep order) against `model`. `colour_space` names the
// values; progress is logged per image.
FlakeStats extract_flakes(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                          const brdf::Brdf& model, const FlakeOptions& options = {},
                          const ExtractionOptions& extraction = {});
// The same over images in memory (sweep order) with their table angles: a rendered image
// measured as a session's is (`paintlab render --compare`).
FlakeStats extract_flakes(const std::vector<std::pair<const ExrImage*, double>>& images,
                          const calib::RigCalibration& calibration, const brdf::Brdf& model,
                          const FlakeOptions& options = {}, const ExtractionOptions& extraction = {});

// The earth mover's distance between two slices' colour distributions (their clusters'
// means with their probabilities; CIELAB Euclidean distance as the ground cost, dE76): an
// exact transport by LEMON's network simplex (flake_transport below). 0 when either is empty.
double flake_colour_emd(const std::vector<FlakeCluster>& a, const std::vector<FlakeCluster>& b);

// The optimal transport behind flake_colour_emd: the flows (cluster `from` of a to cluster
// `to` of b, mass in probability; at most a.size() + b.size() - 1 of them, a basic solution)
// and their cost at the exact distances (dE76 x mass; the solver works on masses scaled to
// kFlakeTransportMass and costs to 1 / kFlakeTransportCostScale dE, so the cost is optimal to
// about 1e-10 dE). The masses out of a cluster sum to its probability (normalised over its
// slice) within 1 / kFlakeTransportMass.
// Empty for an empty side; DataError for negative probabilities or a side without mass.
inline constexpr long long kFlakeTransportMass = 1'000'000'000'000'000;  // 1e15: masses to 1e-15
inline constexpr double kFlakeTransportCostScale = 1e10;  // 1e-10 dE; 500 dE is 5e12, far below 2^63
struct FlakeTransport {
  struct Flow {
    std::size_t from = 0, to = 0;
    double mass = 0.0;
  };
  std::vector<Flow> flows;
  double cost = 0.0;
};
FlakeTransport flake_transport(const std::vector<FlakeCluster>& a, const std::vector<FlakeCluster>& b);

// Entry k of `steps`: the cluster where the cumulative probability passes (k + 0.5) / steps
// (clusters in their order; at most 256 clusters: DataError beyond).
std::vector<std::uint8_t> flake_inverse_cdf(const std::vector<FlakeCluster>& clusters, int steps);

// A colour drawn from a cluster (a contrast colour, linear RGB): the cluster mean's
// chromaticity at a lightness L* = lo.L + u (hi.L - lo.L), u in [0, 1). Drawing a*, b* and L*
// independently in the cuboid would pair dim glints with the chroma of bright ones: the
// chromaticity is kept instead (docs/sparkle.md "Rendering with sparkle").
Eigen::Vector3d draw_flake_colour(const FlakeCluster& cluster, double u);

// The clusters' colours at equal lightness: each mean taken to luminance Y = 1 (L* 100)
// with its chromaticity kept, the boxes dropped. The colour of the flakes apart from their
// intensity (compared by itself): what flake_colour_emd compares in docs/sparkle.md.
std::vector<FlakeCluster> flake_chromaticities(const std::vector<FlakeCluster>& clusters);

// Sparkle drawn from the measured statistics, for renderers (docs/sparkle.md "Rendering
// with sparkle"). A surface cell (an id fixed on the surface: the pixel of a camera that
// does not move relative to the sample) draws random numbers from its id and the cell of a
// grid of 2 x lifetime on the hemisphere of air half vectors (azimuthal-equidistant, offset
// at random per surface cell) that its half vector is in: it glints when the first is below
// the sparkle area of the slice of its directions, in a contrast colour drawn from the
// slice's clusters (inverse CDF, then uniformly in the cluster's CIELAB box) times the
// smooth model's luminance there; otherwise it is darker by what keeps the slice's average,
// area E[c] Y / (1 - area). The draws stay while the half vector stays in its grid cell, and
// the slices' areas and colours change little from one slice to the next: chords across the
// grid's cells average pi lifetime / 2, as a flake's cone does, so a glint lasts about the
// measured lifetime. Deterministic: the same cell, directions and seed give the same value.
class FlakeSparkle {
 public:
  explicit FlakeSparkle(const FlakeStats& stats, std::uint64_t seed = 1);
  // wi, wo in the shading frame (z the normal); `model`: the smooth BRDF there. Returns the
  // BRDF to add (negative where the cell is dark).
  brdf::Rgb delta(std::uint64_t cell, const Vec3& wi, const Vec3& wo, const brdf::Rgb& model) const;
  bool empty() const { return slices_.empty(); }

 private:
  struct Slice {
    double area = 0.0;
    Eigen::Vector3d mean_colour = Eigen::Vector3d::Zero();  // E[c], linear RGB
    std::vector<FlakeCluster> clusters;
    std::vector<std::uint8_t> inverse_cdf;
  };
  int num_f_ = 1, num_i_ = 1;
  double ior_ = 1.5;
  bool mono_ = false;
  double grid_rad_;
  std::uint64_t seed_;
  std::vector<int> index_;    // per bin (theta_i-major): into slices_, -1 none
  std::vector<Slice> slices_;
};

// A session's flakes (`paintlab flakes SESSION`): its finished positions in sweep order,
// its calibration (calib_dir, default: its rig's), against the model of `fit_file` (a
// fit.json, .axf.h5 or paint .toml) or, without one, a Cook-Torrance fit of `lobes` lobes
// made now from the session's binned table.
struct SessionFlakeOptions {
  FlakeOptions flakes;
  ExtractionOptions extraction;
  std::filesystem::path fit_file;
  int lobes = 3;
  std::optional<std::filesystem::path> calib_dir;
};
FlakeStats session_flakes(const std::filesystem::path& session_dir, const SessionFlakeOptions& options);
// The same against a given model (`paintlab export --flakes auto`: the fit just made).
FlakeStats session_flakes(const acq::SessionDir& session, const brdf::Brdf& model, const FlakeOptions& options,
                          const ExtractionOptions& extraction,
                          const std::optional<std::filesystem::path>& calib_dir = std::nullopt);

// flakes.json: {"format": "paintlab-flakes", "format_version": 1, ...} (docs/sparkle.md).
Json flakes_to_json(const FlakeStats& stats);
FlakeStats flakes_from_json(const Json& j, const std::string& where);
// A summary for people: the figures, the instrument numbers, the busiest slices.
std::string describe_flakes(const FlakeStats& stats);

}  // namespace paintlab::fit
