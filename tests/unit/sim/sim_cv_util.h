#pragma once
// The simulated camera in OpenCV's terms, for the tests that compare against OpenCV.
#include <opencv2/core.hpp>

#include "paintlab/sim/camera_model.h"

namespace paintlab::sim::test {

// The 3 x 3 camera matrix K as a CV_64F cv::Mat.
inline cv::Mat cv_camera_matrix(const CameraModel& cam) {
  const Mat3 k = cam.K();
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = k(r, c);
  return m;
}

}  // namespace paintlab::sim::test
