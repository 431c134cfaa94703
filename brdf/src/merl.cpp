#include "paintlab/brdf/merl.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <limits>
#include <numbers>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"

namespace paintlab::brdf {

static_assert(std::endian::native == std::endian::little,
              "the MERL .binary layout is little-endian; a big-endian port must swap bytes");

namespace {
constexpr double kPi = std::numbers::pi;
constexpr double kNaNf = std::numeric_limits<float>::quiet_NaN();

// phi_d reduced to [0, pi] the way the reference does it (one addition of pi).
double reduce_phi_d(double phi_d) { return phi_d < 0.0 ? phi_d + kPi : phi_d; }
}  // namespace

namespace {
// Truncation towards zero as the reference's int() cast, safe for NaN and huge values.
int truncate_clamped(double t, int n) {
  if (!(t >= 0.0)) return 0;  // negative or NaN
  if (t >= n) return n - 1;
  return static_cast<int>(t);
}
}  // namespace

int merl_theta_h_index(double theta_h) {
  if (!(theta_h > 0.0)) return 0;
  // sqrt(theta_h / (pi/2) * 90 * 90), multiplied in the reference's order.
  const double deg_scaled = theta_h / (kPi / 2.0) * kMerlThetaH;
  const double t = std::sqrt(deg_scaled * kMerlThetaH);
  return truncate_clamped(t, kMerlThetaH);
}

int merl_theta_d_index(double theta_d) {
  return truncate_clamped(theta_d / (kPi * 0.5) * kMerlThetaD, kMerlThetaD);
}

int merl_phi_d_index(double phi_d) {
  phi_d = reduce_phi_d(phi_d);
  // The reference writes 180 as 360 / 2 (its constant counts the full circle).
  return truncate_clamped(phi_d / kPi * (2 * kMerlPhiD) / 2, kMerlPhiD);
}

MerlBin merl_bin(const HalfDiff& hd) {
  return {merl_theta_h_index(hd.theta_h), merl_theta_d_index(hd.theta_d), merl_phi_d_index(hd.phi_d)};
}

MerlBin merl_bin_of_flat(std::size_t flat) {
  MerlBin b;
  b.phi_d = static_cast<int>(flat % kMerlPhiD);
  flat /= kMerlPhiD;
  b.theta_d = static_cast<int>(flat % kMerlThetaD);
  b.theta_h = static_cast<int>(flat / kMerlThetaD);
  return b;
}

double merl_theta_h_centre(int i) {
  const double u = (i + 0.5) / kMerlThetaH;
  return u * u * (kPi / 2.0);
}
double merl_theta_d_centre(int j) { return (j + 0.5) / kMerlThetaD * (kPi / 2.0); }
double merl_phi_d_centre(int k) { return (k + 0.5) / kMerlPhiD * kPi; }

Eigen::Vector3d merl_bin_centre(std::size_t flat) {
  const MerlBin b = merl_bin_of_flat(flat);
  return {merl_theta_h_centre(b.theta_h), merl_theta_d_centre(b.theta_d), merl_phi_d_centre(b.phi_d)};
}

const char* to_string(BinState s) {
  static constexpr EnumNames<BinState, 3> kNames{
      {{BinState::Empty, "empty"}, {BinState::Measured, "measured"}, {BinState::Filled, "filled"}}};
  return enum_name(kNames, s);
}

MerlTable::MerlTable()
    : value_(3 * kMerlBins, -1.0),
      variance_(3 * kMerlBins, 0.0f),
      mean_(3 * kMerlBins, kNaNf),
      count_(kMerlBins, 0),
      state_(kMerlBins, BinState::Empty) {}

Eigen::Vector3d MerlTable::mean_coords(std::size_t bin) const {
  if (count_[bin] == 0 || std::isnan(mean_[3 * bin])) return merl_bin_centre(bin);
  return {mean_[3 * bin], mean_[3 * bin + 1], mean_[3 * bin + 2]};
}

void MerlTable::set_value(std::size_t bin, const Rgb& value, BinState state) {
  state_[bin] = state;
  for (int c = 0; c < 3; ++c) value_[3 * bin + c] = state == BinState::Empty ? -1.0 : value[c];
}

void MerlTable::set_statistics(std::size_t bin, std::uint32_t count, const Rgb& variance,
                               const Eigen::Vector3d& mean_coords) {
  count_[bin] = count;
  for (int c = 0; c < 3; ++c) {
    variance_[3 * bin + c] = static_cast<float>(variance[c]);
    mean_[3 * bin + c] = static_cast<float>(mean_coords[c]);
  }
}

std::size_t MerlTable::count_in_state(BinState s) const {
  return static_cast<std::size_t>(std::count(state_.begin(), state_.end(), s));
}

std::optional<Rgb> MerlTable::lookup_nearest(const HalfDiff& hd) const {
  const std::size_t bin = merl_flat_index(merl_bin(hd));
  if (state_[bin] == BinState::Empty) return std::nullopt;
  return value(bin);
}

std::optional<Rgb> MerlTable::lookup(const HalfDiff& hd) const {
  // Continuous cell coordinates: bin i spans [i, i + 1), its centre is at i + 0.5.
  if (!std::isfinite(hd.theta_h) || !std::isfinite(hd.theta_d) || !std::isfinite(hd.phi_d)) return std::nullopt;
  const double th = std::max(hd.theta_h, 0.0);
  double u = std::sqrt(th / (kPi / 2.0)) * kMerlThetaH - 0.5;
  double v = hd.theta_d / (kPi / 2.0) * kMerlThetaD - 0.5;
  double phi = std::fmod(hd.phi_d, kPi);
  if (phi < 0) phi += kPi;
  double w = phi / kPi * kMerlPhiD - 0.5;
  u = std::clamp(u, 0.0, kMerlThetaH - 1.0);
  v = std::clamp(v, 0.0, kMerlThetaD - 1.0);
  const int i0 = std::min(static_cast<int>(u), kMerlThetaH - 2);
  const int j0 = std::min(static_cast<int>(v), kMerlThetaD - 2);
  const double fu = u - i0, fv = v - j0;
  const double wf = std::floor(w);
  const double fw = w - wf;
  const int k0 = (static_cast<int>(wf) + kMerlPhiD) % kMerlPhiD;  // wf >= -1: phi_d wraps with period pi
  const int k1 = (k0 + 1) % kMerlPhiD;

  Rgb sum = Rgb::Zero();
  double wsum = 0;
  for (int a = 0; a < 2; ++a) {
    const double wa = a ? fu : 1.0 - fu;
    for (int b = 0; b < 2; ++b) {
      const double wb = b ? fv : 1.0 - fv;
      for (int c = 0; c < 2; ++c) {
        const double weight = wa * wb * (c ? fw : 1.0 - fw);
        if (weight <= 0.0) continue;
        const std::size_t bin = merl_flat_index({i0 + a, j0 + b, c ? k1 : k0});
        if (state_[bin] == BinState::Empty) continue;
        sum += weight * value(bin);
        wsum += weight;
      }
    }
  }
  if (wsum <= 1e-12) return std::nullopt;
  return Rgb(sum / wsum);
}

std::string encode_merl(const MerlTable& table) {
  std::string bytes(kMerlFileBytes, '\0');
  const std::int32_t dims[3] = {kMerlThetaH, kMerlThetaD, kMerlPhiD};
  std::memcpy(bytes.data(), dims, sizeof dims);
  std::vector<double> plane(kMerlBins);
  // The format's negative numbers mean "missing": a measured bin whose mean is below zero in a
  // channel (noise about a black level, a colour matrix's negative lobe on a tinted glint) is
  // written as 0 there, so that it reads back as measured (the coverage map keeps the mean).
  for (int c = 0; c < 3; ++c) {
    for (std::size_t b = 0; b < kMerlBins; ++b) {
      const double v = table.value(b)[c];
      plane[b] = table.state(b) == BinState::Empty ? -1.0 : (v < 0.0 ? 0.0 : v) / kMerlScale[c];
    }
    std::memcpy(bytes.data() + sizeof dims + c * kMerlBins * sizeof(double), plane.data(),
                kMerlBins * sizeof(double));
  }
  return bytes;
}

MerlTable decode_merl(std::string_view bytes, const std::string& source) {
  if (bytes.size() != kMerlFileBytes)
    throw DataError(fmt::format("{}: expected {} bytes, got {} (a MERL table is 3 int32 dimensions 90 x 90 x 180 "
                                "followed by 3 x 1458000 doubles)",
                                source, kMerlFileBytes, bytes.size()));
  std::int32_t dims[3];
  std::memcpy(dims, bytes.data(), sizeof dims);
  if (dims[0] != kMerlThetaH || dims[1] != kMerlThetaD || dims[2] != kMerlPhiD)
    throw DataError(fmt::format("{}: dimensions {} x {} x {}, expected 90 x 90 x 180", source, dims[0], dims[1],
                                dims[2]));
  MerlTable table;
  std::vector<double> planes(3 * kMerlBins);
  std::memcpy(planes.data(), bytes.data() + sizeof dims, planes.size() * sizeof(double));
  std::size_t non_finite = 0;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    Rgb v;
    bool missing = false;
    for (int c = 0; c < 3; ++c) {
      const double raw = planes[c * kMerlBins + b];
      if (!std::isfinite(raw)) ++non_finite;
      if (!(raw >= 0.0)) missing = true;
      v[c] = raw * kMerlScale[c];
    }
    table.set_value(b, v, missing ? BinState::Empty : BinState::Measured);
  }
  if (non_finite > 0)
    throw DataError(fmt::format("{}: {} values are not finite numbers (NaN or infinity)", source, non_finite));
  return table;
}

MerlTable read_merl(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  return decode_merl(bytes, path.string());
}

void write_merl(const std::filesystem::path& path, const MerlTable& table) {
  write_file_atomic(path, encode_merl(table));
}

MerlTable tabulate(const Brdf& brdf) {
  MerlTable table;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    const Eigen::Vector3d c = merl_bin_centre(b);
    const DirectionPair d = directions_from_half_diff({c[0], 0.0, c[1], c[2]});
    if (d.wi.z() <= 0.0 || d.wo.z() <= 0.0) continue;
    table.set_value(b, brdf.eval(d.wi, d.wo), BinState::Measured);
  }
  return table;
}

Rgb MerlBrdf::eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
  auto v = table_->lookup(half_diff_from_directions(wi, wo));
  return v ? *v : Rgb::Zero();
}

}  // namespace paintlab::brdf
