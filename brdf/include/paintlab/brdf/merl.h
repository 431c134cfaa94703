#pragma once
// The MERL half-vector table (Matusik et al. 2003; models.md "Half-vector table"):
// 90 theta_h (nonlinear) x 90 theta_d x 180 phi_d bins, RGB, and its .binary file layout.
// Index conventions are those of the public reference reader (BRDFRead.cpp); our
// conversion reproduces its 1215 reference cases (tests/unit/brdf/merl_test.cpp).
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/rusinkiewicz.h"

namespace paintlab::brdf {

inline constexpr int kMerlThetaH = 90;
inline constexpr int kMerlThetaD = 90;
inline constexpr int kMerlPhiD = 180;
inline constexpr std::size_t kMerlBins = std::size_t{kMerlThetaH} * kMerlThetaD * kMerlPhiD;  // 1,458,000
// File size: three int32 dimensions, then 3 x kMerlBins doubles.
inline constexpr std::size_t kMerlFileBytes = 3 * sizeof(std::int32_t) + 3 * kMerlBins * sizeof(double);
// Reader scale per channel (R, G, B): value = stored * scale; writers store value / scale.
inline constexpr std::array<double, 3> kMerlScale = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

// Bin indices of one cell.
struct MerlBin {
  int theta_h = 0;  // 0..89, i = floor(sqrt(theta_h / (pi/2)) * 90)
  int theta_d = 0;  // 0..89, j = floor(theta_d / (pi/2) * 90)
  int phi_d = 0;    // 0..179, k = floor(phi_d' / pi * 180), phi_d' = phi_d (+ pi if negative)
  bool operator==(const MerlBin&) const = default;
};

// Index functions exactly as the reference reader rounds them (clamped to the table).
int merl_theta_h_index(double theta_h);
int merl_theta_d_index(double theta_d);
int merl_phi_d_index(double phi_d);
MerlBin merl_bin(const HalfDiff& hd);
// Flat index into one colour plane: k + 180 * (j + 90 * i).
inline std::size_t merl_flat_index(const MerlBin& b) {
  return static_cast<std::size_t>(b.phi_d) +
         std::size_t{kMerlPhiD} * (static_cast<std::size_t>(b.theta_d) + std::size_t{kMerlThetaD} * b.theta_h);
}
MerlBin merl_bin_of_flat(std::size_t flat);

// Bin centres (radians): theta_h where sqrt(theta_h / (pi/2)) * 90 = i + 0.5, and the
// midpoints of the linear theta_d and phi_d bins.
double merl_theta_h_centre(int i);
double merl_theta_d_centre(int j);
double merl_phi_d_centre(int k);
// (theta_h, theta_d, phi_d) of a bin's centre.
Eigen::Vector3d merl_bin_centre(std::size_t flat);

// What a bin holds.
enum class BinState : std::uint8_t {
  Empty = 0,     // no data (written as a negative value)
  Measured = 1,  // from samples (or exact model values, see tabulate())
  Filled = 2,    // filled from neighbours (hole filling)
};
const char* to_string(BinState s);

// A full MERL table with per-bin statistics. Values are BRDF values in 1/sr (already
// multiplied by the reader scale). Statistics that the .binary layout cannot hold (count,
// variance, mean coordinates, measured vs filled) live only in memory.
class MerlTable {
 public:
  MerlTable();  // every bin Empty, count 0

  BinState state(std::size_t bin) const { return state_[bin]; }
  Rgb value(std::size_t bin) const { return {value_[3 * bin], value_[3 * bin + 1], value_[3 * bin + 2]}; }
  std::uint32_t count(std::size_t bin) const { return count_[bin]; }
  // Per-channel variance of the samples of the bin (0 when unknown).
  Rgb variance(std::size_t bin) const {
    return {variance_[3 * bin], variance_[3 * bin + 1], variance_[3 * bin + 2]};
  }
  // Mean (theta_h, theta_d, phi_d) of the samples in the bin (phi_d reduced to [0, pi] as
  // for indexing). Falls back to the bin centre when count(bin) == 0. Fitting should
  // evaluate models here, not at the centre (models.md: centres bias narrow lobes).
  Eigen::Vector3d mean_coords(std::size_t bin) const;

  // Sets a bin's value and state (Empty ignores the value).
  void set_value(std::size_t bin, const Rgb& value, BinState state);
  // Sets the sample statistics of a bin. mean_coords = (theta_h, theta_d, phi_d).
  void set_statistics(std::size_t bin, std::uint32_t count, const Rgb& variance, const Eigen::Vector3d& mean_coords);
  void set_state(std::size_t bin, BinState state) { state_[bin] = state; }

  std::size_t count_in_state(BinState s) const;

  // Trilinear interpolation between bin centres in the table's own coordinates
  // (sqrt-spaced theta_h, linear theta_d, phi_d periodic with period pi). Empty
  // neighbours are left out and the weights of the others renormalised; nullopt when
  // all eight are empty.
  std::optional<Rgb> lookup(const HalfDiff& hd) const;
  // The value of the bin the angles fall into (nullopt when it is empty).
  std::optional<Rgb> lookup_nearest(const HalfDiff& hd) const;

 private:
  std::vector<double> value_;     // 3 per bin, interleaved RGB
  std::vector<float> variance_;   // 3 per bin
  std::vector<float> mean_;       // 3 per bin (theta_h, theta_d, phi_d); NaN = not set
  std::vector<std::uint32_t> count_;
  std::vector<BinState> state_;
};

// The .binary bytes of a table: int32 90, 90, 180, then all R, all G, all B as doubles
// divided by the channel scale; empty bins are written as -1. Little-endian, as the
// reference reader expects on the machines it runs on.
std::string encode_merl(const MerlTable& table);
// Parses .binary bytes. Throws DataError naming `source` on a wrong size or dimensions
// ("FILE: expected 34992012 bytes, got N"). Bins with any negative channel are Empty;
// the others are Measured (the layout cannot say whether a bin was filled).
MerlTable decode_merl(std::string_view bytes, const std::string& source);
MerlTable read_merl(const std::filesystem::path& path);  // IoError, DataError
void write_merl(const std::filesystem::path& path, const MerlTable& table);  // atomic (temp + rename)

// Tabulates a model: every bin gets f at its centre (phi_h = 0), state Measured, count
// 0. Bins whose centre puts wi or wo below the horizon stay Empty.
MerlTable tabulate(const Brdf& brdf);

// A measured BRDF: the table with trilinear lookup. Returns zero below the horizon and
// where the lookup has no data.
class MerlBrdf final : public Brdf {
 public:
  explicit MerlBrdf(std::shared_ptr<const MerlTable> table) : table_(std::move(table)) {}
  Rgb eval(const Vec3& wi, const Vec3& wo) const override;
  std::string model() const override { return "merl"; }
  const MerlTable& table() const { return *table_; }

 private:
  std::shared_ptr<const MerlTable> table_;
};

}  // namespace paintlab::brdf
