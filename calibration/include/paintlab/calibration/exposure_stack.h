#pragma once
// An exposure stack: raw camera images of one static scene taken with different exposure
// times. The input of response recovery (response.h) and of HDR merging (acquisition).
#include <cstdint>
#include <array>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "paintlab/core/image.h"

namespace paintlab::calib {

// One image of a stack, by reference: raw values (bit_depth significant bits, LSB-aligned)
// and the exposure time that produced them (the applied value, seconds).
struct StackFrame {
  const Image<std::uint16_t>* pixels = nullptr;
  double exposure_s = 0.0;
};

// Throws DataError naming the first problem: fewer than `min_frames` frames, a missing image,
// sizes or channel counts (1 or 3) that differ, an exposure that is not finite and > 0,
// or a value above 2^bit_depth - 1.
void check_stack(std::span<const StackFrame> frames, int bit_depth, int min_frames = 2);

// Stack images loaded from files (PNG, TIFF, PGM: 8 or 16 bit, 1 or 3 channels).
struct ExposureStack {
  std::vector<Image<std::uint16_t>> images;
  std::vector<double> exposures_s;
  std::vector<std::filesystem::path> files;
  int bit_depth = 8;  // significant bits of every image
  // A colour-filter-array (Bayer) camera's frames: the camera channel (0 R, 1 G, 2 B) of each
  // pixel of the top-left 2x2 block, row by row. Unset: monochrome or three-channel frames.
  std::optional<std::array<int, 4>> cfa{};

  std::vector<StackFrame> frames() const;
};

// Loads `files` with their exposure times (same order). bit_depth 0 takes the files' own
// depth (8 or 16); 10, 12 or 14 declares fewer significant bits in 16-bit files (values
// written MSB-aligned, i.e. all multiples of 2^(16-bits), are shifted down). Throws
// UsageError when the counts differ, IoError/DataError naming the file that is unreadable,
// of another size, depth or channel count, or whose values do not fit bit_depth.
ExposureStack load_exposure_stack(const std::vector<std::filesystem::path>& files,
                                  const std::vector<double>& exposures_s, int bit_depth = 0);

// The stack of `images` (files or folders of raw images, as the user gave them under
// --images) with their exposure times from `exposures` (a list, parse_exposure_list), or
// from `exposure_file` (read_exposure_file), or, for a single folder, from its
// exposures.txt. UsageError when both or neither are given or the counts differ.
ExposureStack load_stack_files(const std::vector<std::string>& images, const std::string& exposures,
                               const std::filesystem::path& exposure_file, int bit_depth = 0);

// Parses "0.001,0.004,1/60" (seconds; a/b fractions allowed). Throws UsageError naming
// the entry (1-based) and `option` when an entry is not a finite number > 0.
std::vector<double> parse_exposure_list(const std::string& list, const std::string& option = "--exposures");
// Parses one exposure time ("0.25", "1/1024"); returns false when it is not a finite number > 0.
bool parse_exposure_time(const std::string& text, double* seconds);

// Reads `name time` lines (blank lines and # comments ignored) and returns the time of each
// of `files`, matched by path as given or by file name. Throws IoError, or DataError naming
// FILE:LINE for a malformed line and the image that has no time.
std::vector<double> read_exposure_file(const std::filesystem::path& path,
                                       const std::vector<std::filesystem::path>& files);

}  // namespace paintlab::calib
