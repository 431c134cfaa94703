#include "paintlab/calibration/exposure_stack.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/input_files.h"

namespace fs = std::filesystem;

namespace paintlab::calib {

void check_stack(std::span<const StackFrame> frames, int bit_depth, int min_frames) {
  if (static_cast<int>(frames.size()) < min_frames)
    throw DataError(fmt::format("exposure stack: {} image(s) given, at least {} needed", frames.size(), min_frames));
  if (bit_depth < 1 || bit_depth > 16)
    throw DataError(fmt::format("exposure stack: bit depth {} is not in 1..16", bit_depth));
  const std::uint32_t max_value = (1u << bit_depth) - 1u;
  const Image<std::uint16_t>* first = nullptr;
  for (std::size_t j = 0; j < frames.size(); ++j) {
    const auto* img = frames[j].pixels;
    if (img == nullptr || img->empty()) throw DataError(fmt::format("exposure stack: image {} is empty", j + 1));
    if (img->channels() != 1 && img->channels() != 3)
      throw DataError(fmt::format("exposure stack: image {} has {} channels (1 or 3 supported)", j + 1, img->channels()));
    if (!first) first = img;
    if (img->width() != first->width() || img->height() != first->height() || img->channels() != first->channels())
      throw DataError(fmt::format("exposure stack: image {} is {}x{}x{}, image 1 is {}x{}x{}", j + 1, img->width(),
                                  img->height(), img->channels(), first->width(), first->height(), first->channels()));
    const double t = frames[j].exposure_s;
    if (!std::isfinite(t) || t <= 0.0)
      throw DataError(fmt::format("exposure stack: image {} has exposure {} s (must be finite and > 0)", j + 1, t));
    if (bit_depth < 16) {
      const auto top = *std::max_element(img->values().begin(), img->values().end());
      if (top > max_value)
        throw DataError(fmt::format("exposure stack: image {} holds the value {}, above {} ({} bits)", j + 1, top,
                                    max_value, bit_depth));
    }
  }
}

std::vector<StackFrame> ExposureStack::frames() const {
  std::vector<StackFrame> out;
  out.reserve(images.size());
  for (std::size_t j = 0; j < images.size(); ++j) out.push_back({&images[j], exposures_s[j]});
  return out;
}

ExposureStack load_exposure_stack(const std::vector<fs::path>& files, const std::vector<double>& exposures_s,
                                  int bit_depth) {
  if (files.empty()) throw UsageError("no images given");
  if (files.size() != exposures_s.size())
    throw UsageError(fmt::format("{} images but {} exposure times: give one time per image, in the same order",
                                 files.size(), exposures_s.size()));
  if (bit_depth != 0 && bit_depth != 8 && bit_depth != 10 && bit_depth != 12 && bit_depth != 14 && bit_depth != 16)
    throw UsageError(fmt::format("bit depth {} is not one of 8, 10, 12, 14, 16", bit_depth));
  ExposureStack stack;
  int file_depth = 0;
  for (std::size_t j = 0; j < files.size(); ++j) {
    RawImage raw = read_raw_image(files[j]);
    if (j == 0) {
      file_depth = raw.bit_depth;
    } else {
      const auto& a = stack.images.front();
      if (raw.bit_depth != file_depth)
        throw DataError(fmt::format("{}: {}-bit image, but {} is {}-bit", files[j].string(), raw.bit_depth,
                                    files[0].string(), file_depth));
      if (raw.pixels.width() != a.width() || raw.pixels.height() != a.height() || raw.pixels.channels() != a.channels())
        throw DataError(fmt::format("{}: {}x{} with {} channel(s), but {} is {}x{} with {} channel(s)",
                                    files[j].string(), raw.pixels.width(), raw.pixels.height(), raw.pixels.channels(),
                                    files[0].string(), a.width(), a.height(), a.channels()));
    }
    stack.images.push_back(std::move(raw.pixels));
  }
  const int depth = bit_depth == 0 ? file_depth : bit_depth;
  if (depth > file_depth)
    throw UsageError(fmt::format("bit depth {} declared, but the files are {}-bit", depth, file_depth));
  if (depth < file_depth) {
    // Fewer significant bits than stored: LSB-aligned values must fit; MSB-aligned ones
    // (every value a multiple of 2^shift) are shifted down.
    const int shift = file_depth - depth;
    const std::uint16_t max_value = static_cast<std::uint16_t>((1u << depth) - 1u);
    bool fits = true;
    bool aligned = true;
    const std::uint16_t low_mask = static_cast<std::uint16_t>((1u << shift) - 1u);
    for (const auto& img : stack.images)
      for (std::uint16_t v : img.values()) {
        fits = fits && v <= max_value;
        aligned = aligned && (v & low_mask) == 0;
      }
    if (!fits) {
      if (!aligned)
        throw DataError(fmt::format("{} ...: values exceed {} ({} bits) and are not MSB-aligned multiples of {}",
                                    files[0].string(), max_value, depth, 1u << shift));
      for (auto& img : stack.images)
        for (auto& v : img.values()) v = static_cast<std::uint16_t>(v >> shift);
    }
  }
  stack.exposures_s = exposures_s;
  stack.files = files;
  stack.bit_depth = depth;
  auto frames = stack.frames();
  check_stack(frames, depth, 1);
  return stack;
}

bool parse_exposure_time(const std::string& text, double* seconds) {
  std::string s = text;
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t") + 1);
  if (s.empty()) return false;
  auto parse_number = [](const std::string& part, double* out) {
    if (part.empty()) return false;
    char* end = nullptr;
    *out = std::strtod(part.c_str(), &end);
    return end == part.c_str() + part.size();
  };
  double value = 0.0;
  const auto slash = s.find('/');
  if (slash == std::string::npos) {
    if (!parse_number(s, &value)) return false;
  } else {
    double num = 0.0;
    double den = 0.0;
    if (!parse_number(s.substr(0, slash), &num) || !parse_number(s.substr(slash + 1), &den) || den == 0.0) return false;
    value = num / den;
  }
  if (!std::isfinite(value) || value <= 0.0) return false;
  *seconds = value;
  return true;
}

std::vector<double> parse_exposure_list(const std::string& list, const std::string& option) {
  std::vector<double> out;
  std::size_t start = 0;
  int index = 0;
  while (true) {
    const auto comma = list.find(',', start);
    const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    ++index;
    double t = 0.0;
    if (!parse_exposure_time(item, &t))
      throw UsageError(fmt::format("{}: entry {} '{}' is not an exposure time in seconds (a number > 0, or a/b)",
                                   option, index, item));
    out.push_back(t);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

std::vector<double> read_exposure_file(const fs::path& path, const std::vector<fs::path>& files) {
  std::ifstream in(path);
  if (!in) throw IoError(path.string(), "cannot open the exposure file", errno);
  struct Entry {
    std::string name;
    double time_s;
    int line;
  };
  std::vector<Entry> entries;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream ss(line);
    std::string name;
    std::string time;
    std::string extra;
    if (!(ss >> name)) continue;
    if (!(ss >> time) || (ss >> extra))
      throw DataError(fmt::format("{}:{}: expected 'name time' (two fields)", path.string(), line_no));
    double t = 0.0;
    if (!parse_exposure_time(time, &t))
      throw DataError(fmt::format("{}:{}: '{}' is not an exposure time in seconds (a number > 0, or a/b)",
                                  path.string(), line_no, time));
    for (const auto& e : entries)
      if (e.name == name)
        throw DataError(fmt::format("{}:{}: '{}' is listed twice (first at line {})", path.string(), line_no, name,
                                    e.line));
    entries.push_back({name, t, line_no});
  }
  std::vector<double> out;
  for (const auto& f : files) {
    const Entry* hit = nullptr;
    for (const auto& e : entries)
      if (e.name == f.string()) hit = &e;
    if (!hit)
      for (const auto& e : entries)
        if (fs::path(e.name).filename() == f.filename()) hit = &e;
    if (!hit) throw DataError(fmt::format("{}: no exposure time for image '{}'", path.string(), f.string()));
    out.push_back(hit->time_s);
  }
  return out;
}

ExposureStack load_stack_files(const std::vector<std::string>& images, const std::string& exposures,
                               const std::filesystem::path& exposure_file, int bit_depth) {
  namespace fs = std::filesystem;
  const auto files = expand_input_files(images, "--images", kRawImageExtensions);
  std::vector<double> times;
  if (!exposures.empty() && !exposure_file.empty())
    throw UsageError("give either --exposures or --exposure-file, not both");
  if (!exposures.empty()) {
    times = parse_exposure_list(exposures, "--exposures");
  } else if (!exposure_file.empty()) {
    times = read_exposure_file(exposure_file, files);
  } else if (images.size() == 1 && fs::is_directory(images[0]) && fs::exists(fs::path(images[0]) / "exposures.txt")) {
    times = read_exposure_file(fs::path(images[0]) / "exposures.txt", files);
  } else {
    throw UsageError("give the exposure times: --exposures LIST or --exposure-file F");
  }
  if (times.size() != files.size())
    throw UsageError(fmt::format("--exposures gives {} times for {} images: give one time per image, in the same order",
                                 times.size(), files.size()));
  return load_exposure_stack(files, times, bit_depth);
}

}  // namespace paintlab::calib
