#pragma once
// The camera response curve: raw value -> linear signal, recovered from an exposure stack
// by Robertson's method (Robertson, Borman, Stevenson, "Estimation-theoretic approach to
// dynamic range enhancement using multiple exposures", JEI 2003) or Debevec's (Debevec,
// Malik, SIGGRAPH 97), using every pixel of every exposure. Written as calib/response.json.
//
// Model: a raw value z of pixel p in an image of exposure t is z = dark_p(t) + f(X_p t);
// the curve stored here is g = f^-1 as a function of u = z - dark (the dark frame of
// dark.json, or a scalar black level), piecewise linear between knots: one knot per value
// for 8-bit data, at most `max_knots` uniformly spaced knots for 10..16-bit data.
// g is scaled so that its least-squares slope against u over the used range is 1: linear
// values are in "linearised DN", and a perfectly linear camera has g(u) = u.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

struct DarkFrame;

// How much a raw value counts, in response recovery and HDR merging. Every weighting is
// zero at and above saturation and at and below the noise floor.
enum class Weighting {
  Robertson,        // Gaussian-like certainty over the usable range (Robertson et al.; OpenCV's shape)
  Hat,              // triangle over the usable range (Debevec and Malik)
  // Robertson's certainty divided by the variance of the linear value (noise model): the
  // maximum-likelihood weights of Robertson et al. 2003, the certainty keeping the unreliable
  // ends (toe, shoulder) out. Merging only.
  InverseVariance,
};
const char* to_string(Weighting w);
Weighting weighting_from_string(const std::string& s, std::string_view where = {});  // DataError naming the value

enum class ResponseMethod { Robertson, Debevec };
const char* to_string(ResponseMethod m);
ResponseMethod response_method_from_string(const std::string& s, std::string_view where = {});

// Temporal noise of one dark-subtracted raw value u, in DN^2: read + shot.
struct NoiseModel {
  double read_noise_dn = 0.0;   // std of a dark pixel, quantisation included
  double gain_dn_per_e = 0.0;   // conversion gain: shot variance = gain * u
  std::string source;           // where the numbers come from; empty = unknown

  bool known() const { return !source.empty(); }
  // max(read^2, 1/12) + gain * max(u, 0)
  double variance_dn2(double u) const;
  Json to_json() const;
  static NoiseModel from_json(const Json& j, const std::string& where);
};

// The usable range of raw values.
struct ValueWindow {
  double floor_dn = 0.0;          // u (dark-subtracted) at or below: weight 0 (noise floor)
  double saturation_dn = 255.0;   // raw value at or above: weight 0 (saturation)
  double black_dn = 0.0;          // typical dark level: the usable u range is (floor, saturation - black)

  double u_saturation() const { return saturation_dn - black_dn; }
};

// Certainty in [0, 1] of a dark-subtracted value u under Robertson or Hat weighting (for
// InverseVariance: Robertson's, which multiplies 1/variance). Zero outside (floor, u_saturation).
double certainty(Weighting w, double u, const ValueWindow& window);

struct ResponseFitReport {
  long long samples_used = 0;               // samples with nonzero weight
  // After linearisation: robust spread (1.4826 x median absolute deviation) of g(u) / (t E) - 1
  // over well-exposed samples (certainty >= 0.5), E the merged value of the pixel. The
  // "linearity" a rig check compares with its tolerance. linearity_rms_rel: the plain RMS
  // (sensitive to moving objects and misregistration).
  double linearity_error_rel = 0.0;
  double linearity_rms_rel = 0.0;
  // How nonlinear the raw camera is, per channel: largest deviation of g from its best
  // straight line over the used range, relative to g at saturation.
  std::vector<double> nonlinearity_rel;
  // Per channel: largest decrease of the unconstrained curve between knots with data in the
  // used range, relative to g at saturation (0: increasing). The stored curve is the
  // weighted least-squares non-decreasing projection (pool adjacent violators).
  std::vector<double> monotonic_violation_rel;
  // Per image: median of g(u) / (t E) over well-exposed samples (1 when its exposure time
  // is consistent with the others).
  std::vector<double> exposure_ratio;
};

struct ResponseCurve {
  ResponseMethod method = ResponseMethod::Robertson;
  Weighting weighting = Weighting::Robertson;
  int bit_depth = 8;
  int channels = 1;
  ValueWindow window;
  bool dark_subtracted = false;              // u = raw - dark map (dark.json), else raw - black_dn
  std::vector<double> knots_dn;              // u at the knots, ascending, uniform spacing
  std::vector<std::vector<double>> linear;   // [channel][knot]: g at the knot
  // [channel][knot]: robust spread (1.4826 x median absolute deviation) of g(u) - t E over the
  // samples nearest each knot, in linear units: how far the exposure of a pixel that shows
  // u may lie from g(u). The HDR merge's noise model (variance = residual_std^2).
  std::vector<std::vector<double>> residual_std;
  NoiseModel noise;                          // read + shot model fitted to residual_std
  ResponseFitReport report;
  Provenance provenance;

  // g(u), piecewise linear; beyond the knots the end segments are extended.
  double to_linear(int channel, double u) const;
  // dg/du of the segment holding u.
  double slope(int channel, double u) const;
  // Variance of g(u) as an estimate of t E (linear units^2): residual_std interpolated, or
  // without it slope^2 x noise.variance_dn2(u); 0 when neither is known.
  double variance(int channel, double u) const;

  // g(u) = u over the whole range of `bit_depth` values (a camera known to be linear).
  static ResponseCurve identity(int bit_depth, int channels, const ValueWindow& window);

  // Method, depth, knots, images, the used range, linearity and the noise model (lines).
  std::string describe() const;
  Json to_json() const;
  static ResponseCurve from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;         // atomic
  static ResponseCurve load(const std::filesystem::path& path);  // IoError / DataError naming the file
};

// The no-data colour of --no-data: "R,G,B" or one value (mono), each 0..65535; empty text:
// none. UsageError naming `flag` and the bad item.
std::vector<std::uint16_t> parse_no_data(const std::string& text, std::string_view flag);

struct ResponseOptions {
  ResponseMethod method = ResponseMethod::Robertson;
  // Robertson's method weights with Weighting::Robertson, Debevec's with Weighting::Hat
  // unless this is set to the other one (InverseVariance is for merging only).
  bool use_method_weighting = true;
  Weighting weighting = Weighting::Robertson;
  int max_knots = 256;          // knots for 10..16-bit data (8-bit data: one per value); <= 4096
  double saturation_dn = -1.0;  // < 0: automatic (2^bits - 1, or the level where values pile up)
  double black_dn = 0.0;        // subtracted when no dark frame is given
  double floor_dn = -1.0;       // < 0: automatic (3 x read noise when a dark frame says it, else 0)
  // Curvature penalty, relative to the mean data weight per knot (keeps knots without data
  // defined and the curve smooth; Debevec's lambda plays this role). < 0: the method's
  // default, 1 for Robertson (linear domain) and 1e-3 for Debevec (log domain), chosen on the
  // synthetic stacks of tests/unit/calibration/response_test.cpp. Robertson on a bracket whose
  // exposure ratios are all powers of one step (>= 1.25) also gets a log-log curvature prior
  // weighted by the data's own misfit (docs/radiometry.md, "Constant-ratio brackets").
  double smoothness = -1.0;
  // A colour (one value per channel) that marks pixels without data in an image (e.g. the
  // pure-blue registration borders of Debevec's photos); empty: none.
  std::vector<std::uint16_t> no_data{};

  void check() const;  // UsageError naming the first violated rule
};

// Recovers the response from `frames` (at least 2 exposures, bit_depth significant bits).
// With `dark`, u = raw - dark level of each pixel at the frame's exposure; otherwise
// u = raw - black_dn. Throws DataError (bad stack) or CalibrationError (too few usable
// samples, e.g. every value saturated).
ResponseCurve recover_response(std::span<const StackFrame> frames, int bit_depth, const ResponseOptions& options,
                               const DarkFrame* dark = nullptr);

}  // namespace paintlab::calib
