#include "cv_util.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"

namespace paintlab::calib::detail {

void check_image(const Image<std::uint16_t>& image, int bit_depth, const char* what) {
  if (bit_depth < 8 || bit_depth > 16)
    throw DataError(std::string(what) + ": bit depth must be 8..16 (got " + std::to_string(bit_depth) + ")");
  if (image.empty()) throw DataError(std::string(what) + ": empty image");
  if (image.channels() != 1 && image.channels() != 3)
    throw DataError(std::string(what) + ": 1 or 3 channels expected (got " + std::to_string(image.channels()) + ")");
}

cv::Mat to_unit_float(const Image<std::uint16_t>& image, int bit_depth) {
  const float scale = 1.0f / static_cast<float>((1u << bit_depth) - 1u);
  cv::Mat out(image.height(), image.width(), CV_32F);
  const int ch = image.channels();
  for (int y = 0; y < image.height(); ++y) {
    const std::uint16_t* src = image.row(y);
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < image.width(); ++x) {
      float s = 0.0f;
      for (int c = 0; c < ch; ++c) s += static_cast<float>(src[x * ch + c]);
      dst[x] = s * scale / static_cast<float>(ch);
    }
  }
  return out;
}

cv::Mat to_detection_u8(const cv::Mat& unit_float) {
  std::vector<float> v;
  v.reserve(unit_float.total() / 16 + 1);
  for (int y = 0; y < unit_float.rows; y += 4) {
    const float* p = unit_float.ptr<float>(y);
    for (int x = 0; x < unit_float.cols; x += 4) v.push_back(p[x]);
  }
  const float lo = static_cast<float>(lower_quantile_inplace(v, 0.005));
  float hi = static_cast<float>(lower_quantile_inplace(v, 0.995));
  if (!(hi > lo)) hi = lo + 1e-6f;
  cv::Mat out;
  unit_float.convertTo(out, CV_8U, 255.0 / (hi - lo), -255.0 * lo / (hi - lo));
  return out;
}

}  // namespace paintlab::calib::detail
