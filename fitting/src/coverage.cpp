#include "paintlab/fitting/coverage.h"

#include <fmt/format.h>

#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image_io.h"

namespace paintlab::fit {

using brdf::kMerlBins;
using brdf::kMerlPhiD;
using brdf::kMerlThetaD;
using brdf::kMerlThetaH;

const char* to_string(Region r) {
  static constexpr EnumNames<Region, 3> kNames{
      {{Region::Peak, "peak"}, {Region::Glossy, "glossy"}, {Region::Diffuse, "diffuse"}}};
  return enum_name(kNames, r);
}

Region region_of_theta_h(double theta_h) {
  const double deg = rad_to_deg(theta_h);
  if (deg < kPeakMaxThetaHDeg) return Region::Peak;
  if (deg < kGlossyMaxThetaHDeg) return Region::Glossy;
  return Region::Diffuse;
}

Region region_of_bin(std::size_t bin) { return region_of_theta_h(brdf::merl_theta_h_centre(brdf::merl_bin_of_flat(bin).theta_h)); }

bool bin_geometry_valid(std::size_t bin) {
  const Eigen::Vector3d c = brdf::merl_bin_centre(bin);
  const auto cos = brdf::cosines_from_half_diff(c[0], c[1], c[2]);
  return cos.n_dot_wi > 0.0 && cos.n_dot_wo > 0.0;
}

const std::vector<std::uint8_t>& valid_bin_mask() {
  static const std::vector<std::uint8_t> mask = [] {
    std::vector<std::uint8_t> m(kMerlBins);
    for (std::size_t b = 0; b < kMerlBins; ++b) m[b] = bin_geometry_valid(b) ? 1 : 0;
    return m;
  }();
  return mask;
}

Json RegionCoverage::to_json() const {
  return {{"valid_bins", valid_bins},
          {"measured_bins", measured_bins},
          {"filled_bins", filled_bins},
          {"samples", samples},
          {"measured_fraction", measured_fraction()}};
}

Json CoverageReport::to_json() const {
  Json j = Json::object();
  for (int r = 0; r < kRegionCount; ++r) j[to_string(static_cast<Region>(r))] = regions[r].to_json();
  j["total"] = total.to_json();
  return j;
}

std::string CoverageReport::describe() const {
  std::string s = fmt::format("{:<8} {:>10} {:>10} {:>9} {:>10} {:>12}\n", "region", "valid", "measured", "covered",
                              "filled", "samples");
  auto line = [&](const char* name, const RegionCoverage& c) {
    s += fmt::format("{:<8} {:>10} {:>10} {:>8.1f}% {:>10} {:>12}\n", name, c.valid_bins, c.measured_bins,
                     100.0 * c.measured_fraction(), c.filled_bins, c.samples);
  };
  for (int r = 0; r < kRegionCount; ++r) line(to_string(static_cast<Region>(r)), regions[r]);
  line("total", total);
  return s;
}

CoverageReport coverage(const brdf::MerlTable& table) {
  CoverageReport rep;
  const auto& valid = valid_bin_mask();
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    RegionCoverage& c = rep.regions[static_cast<int>(region_of_bin(b))];
    const bool v = valid[b] != 0;
    // Bins outside the valid domain that hold data (a foreign table) still count as measured.
    if (v) ++c.valid_bins;
    switch (table.state(b)) {
      case brdf::BinState::Measured:
        ++c.measured_bins;
        c.samples += table.count(b);
        break;
      case brdf::BinState::Filled: ++c.filled_bins; break;
      case brdf::BinState::Empty: break;
    }
  }
  for (const RegionCoverage& c : rep.regions) {
    rep.total.valid_bins += c.valid_bins;
    rep.total.measured_bins += c.measured_bins;
    rep.total.filled_bins += c.filled_bins;
    rep.total.samples += c.samples;
  }
  return rep;
}

void coverage_pixel(std::size_t bin, int& x, int& y) {
  const brdf::MerlBin b = brdf::merl_bin_of_flat(bin);
  x = (b.theta_d % kCoverageTilesPerRow) * kMerlPhiD + b.phi_d;
  y = (b.theta_d / kCoverageTilesPerRow) * kMerlThetaH + b.theta_h;
}

std::filesystem::path coverage_map_path_for(const std::filesystem::path& table_file) {
  return table_file.parent_path() / (table_file.stem().string() + ".coverage.exr");
}

std::size_t mark_filled_bins(const std::filesystem::path& coverage_exr, brdf::MerlTable& table) {
  constexpr int tile_rows = (kMerlThetaD + kCoverageTilesPerRow - 1) / kCoverageTilesPerRow;
  const int w = kCoverageTilesPerRow * kMerlPhiD, h = tile_rows * kMerlThetaH;
  const ExrImage img = read_exr(coverage_exr);
  if (img.width != w || img.height != h)
    throw DataError(fmt::format("{}: a coverage map is {} x {} pixels, this one {} x {} (not a coverage map)",
                                coverage_exr.string(), w, h, img.width, img.height));
  const ImageF& state = img.plane("state");
  std::size_t filled = 0;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    int x, y;
    coverage_pixel(b, x, y);
    const float s = state.at(x, y);
    if (s == 0.0f) continue;
    if (table.state(b) == brdf::BinState::Empty)
      throw DataError(fmt::format("{}: marks bin {} as {} but the table has it empty (the map of another table?)",
                                  coverage_exr.string(), b, s == 2.0f ? "filled" : "measured"));
    if (s == 2.0f) {
      table.set_state(b, brdf::BinState::Filled);
      ++filled;
    }
  }
  return filled;
}

void write_coverage_exr(const std::filesystem::path& path, const brdf::MerlTable& table) {
  constexpr int tile_rows = (kMerlThetaD + kCoverageTilesPerRow - 1) / kCoverageTilesPerRow;
  const int w = kCoverageTilesPerRow * kMerlPhiD, h = tile_rows * kMerlThetaH;
  ImageF count(w, h), state(w, h), valid(w, h), r(w, h), g(w, h), bl(w, h);
  const auto& mask = valid_bin_mask();
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    int x, y;
    coverage_pixel(b, x, y);
    count.at(x, y) = static_cast<float>(table.count(b));
    state.at(x, y) = static_cast<float>(static_cast<int>(table.state(b)));
    valid.at(x, y) = mask[b] ? 1.0f : 0.0f;
    if (table.state(b) != brdf::BinState::Empty) {
      const brdf::Rgb v = table.value(b);
      r.at(x, y) = static_cast<float>(v[0]);
      g.at(x, y) = static_cast<float>(v[1]);
      bl.at(x, y) = static_cast<float>(v[2]);
    }
  }
  ExrImage img;
  img.width = w;
  img.height = h;
  img.add("count", std::move(count));
  img.add("state", std::move(state));
  img.add("valid", std::move(valid));
  img.add("R", std::move(r));
  img.add("G", std::move(g));
  img.add("B", std::move(bl));
  img.attributes["paintlab.layout"] = fmt::format(
      "MERL coverage mosaic: theta_d slice j is the tile at column j % {0}, row j / {0}; inside a tile x = phi_d bin "
      "(0..179), y = theta_h bin (0..89)",
      kCoverageTilesPerRow);
  img.attributes["paintlab.state"] = "0 empty, 1 measured, 2 filled";
  write_exr(path, img);
}

}  // namespace paintlab::fit
