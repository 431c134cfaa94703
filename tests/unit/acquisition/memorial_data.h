#pragma once
// Debevec and Malik's Memorial Church stack (tests/data/debevec-memorial) and the
// comparison with their own radiance map memorial.hdr: RMS of the natural-log ratio after one
// scale per channel, over pixels that are not registration border (pure blue) in any photo.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "test_util.h"

namespace paintlab::memorial_test {

namespace fs = std::filesystem;


struct Memorial {
  std::vector<fs::path> files;
  std::vector<double> exposures_s;
  calib::ExposureStack stack;
  std::vector<std::uint8_t> border;  // per pixel: pure blue in some photo
  cv::Mat reference;                 // memorial.hdr, BGR float
};

inline bool load(Memorial* m) {
  const fs::path dir = test::data_dir() / "debevec-memorial";
  if (!fs::exists(dir / "image_list.txt") || !fs::exists(dir / "memorial.hdr")) return false;
  std::ifstream in(dir / "image_list.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string file;
    double relative = 0.0, inverse_shutter = 0.0;
    if (!(ss >> file >> relative >> inverse_shutter)) continue;
    m->files.push_back(dir / file);
    m->exposures_s.push_back(1.0 / inverse_shutter);  // the column is 1 / exposure time
  }
  m->stack = calib::load_exposure_stack(m->files, m->exposures_s);
  const std::size_t P = m->stack.images[0].pixel_count();
  m->border.assign(P, 0);
  for (const auto& img : m->stack.images)
    for (std::size_t p = 0; p < P; ++p)
      if (img.data()[3 * p] == 0 && img.data()[3 * p + 1] == 0 && img.data()[3 * p + 2] == 255) m->border[p] = 1;
  m->reference = cv::imread((dir / "memorial.hdr").string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  return !m->reference.empty();
}

// RMS of ln(ours / reference) after the best scale per channel (the mean log ratio), over
// non-border pixels where both are positive. get(p, c) gives RGB channel c of pixel p.
template <class Get>
double log_rms(const Memorial& m, Get&& get, long* compared = nullptr) {
  const std::size_t P = m.border.size();
  const auto* ref = m.reference.ptr<cv::Vec3f>();
  double offset[3] = {0, 0, 0};
  long count[3] = {0, 0, 0};
  for (std::size_t p = 0; p < P; ++p) {
    if (m.border[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const double a = get(p, c), b = ref[p][2 - c];
      if (!(a > 0.0 && b > 0.0)) continue;
      offset[c] += std::log(a / b);
      ++count[c];
    }
  }
  for (int c = 0; c < 3; ++c) offset[c] /= static_cast<double>(count[c]);
  double sq = 0.0;
  long n = 0;
  for (std::size_t p = 0; p < P; ++p) {
    if (m.border[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const double a = get(p, c), b = ref[p][2 - c];
      if (!(a > 0.0 && b > 0.0)) continue;
      const double d = std::log(a / b) - offset[c];
      sq += d * d;
      ++n;
    }
  }
  if (compared) *compared = n;
  return std::sqrt(sq / static_cast<double>(n));
}

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}


}  // namespace paintlab::memorial_test
