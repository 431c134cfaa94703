#pragma once
// Regions of the half-vector table, what a table covers, and the coverage map.
// Regions by the bin's theta_h (docs/fitting.md "Regions"): peak theta_h < 2.5 deg (the
// clear-coat reflection), glossy 2.5 to 25 deg (the metallic lobes), diffuse >= 25 deg.
// Only bins whose centre has both directions above the horizon count ("valid" bins);
// the others cannot be measured by any rig.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"

namespace paintlab::fit {

enum class Region { Peak = 0, Glossy = 1, Diffuse = 2 };
inline constexpr int kRegionCount = 3;
inline constexpr double kPeakMaxThetaHDeg = 2.5;
inline constexpr double kGlossyMaxThetaHDeg = 25.0;
const char* to_string(Region r);  // "peak", "glossy", "diffuse"

Region region_of_theta_h(double theta_h);  // radians
Region region_of_bin(std::size_t bin);     // by the bin centre's theta_h
// Both directions above the horizon at the bin centre (phi_h = 0).
bool bin_geometry_valid(std::size_t bin);
// The mask of bin_geometry_valid() for all bins (computed once).
const std::vector<std::uint8_t>& valid_bin_mask();

struct RegionCoverage {
  std::size_t valid_bins = 0;     // bins with both directions above the horizon
  std::size_t measured_bins = 0;
  std::size_t filled_bins = 0;
  std::uint64_t samples = 0;      // sum of counts of measured bins
  double measured_fraction() const { return valid_bins ? static_cast<double>(measured_bins) / valid_bins : 0.0; }
  Json to_json() const;
};

struct CoverageReport {
  std::array<RegionCoverage, kRegionCount> regions;  // indexed by Region
  RegionCoverage total;
  Json to_json() const;  // {"peak": {...}, "glossy": {...}, "diffuse": {...}, "total": {...}}
  std::string describe() const;  // a few lines for people
};

CoverageReport coverage(const brdf::MerlTable& table);

// The coverage map: an EXR mosaic of the 90 theta_d slices, 10 per row; each tile is
// 180 px wide (phi_d, 1 deg per px) and 90 px high (theta_h bins, top = 0). Channels:
// "count" (samples), "state" (0 empty, 1 measured, 2 filled), "valid" (1 where both
// directions are above the horizon), "R", "G", "B" (value in 1/sr, 0 where empty).
// Written atomically.
inline constexpr int kCoverageTilesPerRow = 10;
void write_coverage_exr(const std::filesystem::path& path, const brdf::MerlTable& table);
// The pixel of bin `bin` in that mosaic.
void coverage_pixel(std::size_t bin, int& x, int& y);
// Where `paintlab bin` writes the coverage map of a table by default: beside it, the
// table's stem + ".coverage.exr" (t.binary -> t.coverage.exr).
std::filesystem::path coverage_map_path_for(const std::filesystem::path& table_file);
// A MERL file cannot mark filled bins; its coverage map can. Marks the bins whose state in
// the map is "filled" as BinState::Filled in `table` (fits use measured bins only) and
// returns how many. DataError naming the map when it is not a coverage mosaic, or when it
// says a bin holds a value that the table has empty (the map belongs to another table).
std::size_t mark_filled_bins(const std::filesystem::path& coverage_exr, brdf::MerlTable& table);

}  // namespace paintlab::fit
