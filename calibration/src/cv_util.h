#pragma once
// Conversions between paintlab images and OpenCV matrices (private to calibration/).
#include <cstdint>
#include <opencv2/core.hpp>

#include "paintlab/core/image.h"

namespace paintlab::calib::detail {

// Raw values with `bit_depth` significant bits -> CV_32F in [0, 1]; 3 channels are averaged.
cv::Mat to_unit_float(const Image<std::uint16_t>& image, int bit_depth);

// A CV_32F image -> CV_8U stretched between its 0.5 % and 99.5 % quantiles (for detectors
// that only take 8-bit data; localisation keeps using the float image).
cv::Mat to_detection_u8(const cv::Mat& unit_float);

// Throws DataError when bit_depth is not in 8..16 or the image is empty or has 2 or >3 channels.
void check_image(const Image<std::uint16_t>& image, int bit_depth, const char* what);

}  // namespace paintlab::calib::detail
