#pragma once
// Image files: OpenEXR (linear float, named channels) and 8/16-bit PNG/TIFF (raw camera
// values). Writes are atomic (see atomic_file.h).
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "paintlab/core/image.h"

namespace paintlab {

// An EXR with named float channels of one size ("R","G","B","Y","var.R","valid"...).
struct ExrImage {
  int width = 0;
  int height = 0;
  std::vector<std::string> names;       // channel order as given/written
  std::vector<ImageF> planes;           // one single-channel plane per name
  std::map<std::string, std::string> attributes;  // string header attributes

  const ImageF& plane(const std::string& name) const;  // DataError when absent
  ImageF* find(const std::string& name);
  const ImageF* find(const std::string& name) const;
  void add(const std::string& name, ImageF plane);
};

// Writes channels as 32-bit float (or half when `half` is set), ZIP compressed.
void write_exr(const std::filesystem::path& path, const ExrImage& image, bool half = false);
// What read_exr accepts: sides of 1..kMaxExrSide pixels and at most kMaxExrValues values
// (width x height x channels, 512 MB of floats: a 20 Mpx radiance map with six planes fits); a
// header outside them is a DataError before the planes are allocated. A rig's images are a few Mpx.
inline constexpr std::int64_t kMaxExrSide = 32768;
inline constexpr std::int64_t kMaxExrValues = std::int64_t{1} << 27;
struct ExrLimits {
  std::int64_t max_side = kMaxExrSide;      // at most kMaxExrSide (OpenEXR's own check is set to it)
  std::int64_t max_values = kMaxExrValues;  // width x height x channels
};
// `limits` smaller than the defaults are for callers that know their images are small (the
// fuzz harness: so that a mutated header cannot make every run allocate hundreds of MB); a
// smaller side also becomes OpenEXR's own process-wide check, so such a process reads only
// such images.
ExrImage read_exr(const std::filesystem::path& path, const ExrLimits& limits = {});

// A camera-value image read from PNG/TIFF/PGM: 8 or 16 bit, 1 or 3 channels.
struct RawImage {
  Image<std::uint16_t> pixels;  // values as stored (8-bit files give 0..255)
  int bit_depth = 16;           // 8 or 16 as stored in the file
};
RawImage read_raw_image(const std::filesystem::path& path);
// Writes 8-bit when every value fits and bit_depth == 8, else 16-bit PNG.
void write_png(const std::filesystem::path& path, const Image<std::uint16_t>& pixels, int bit_depth);
void write_png8(const std::filesystem::path& path, const Image<std::uint8_t>& pixels);

}  // namespace paintlab
