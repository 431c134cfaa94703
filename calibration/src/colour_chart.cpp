// Finding a ColorChecker 24 in an image: OpenCV's Macbeth chart detector (opencv_contrib's
// mcc module, Debian's libopencv-contrib-dev) gives the corners of the patch area; the patches
// are measured here on the linear image, and the orientation is checked against the reference.
//
// The detector's chart model (mcc, OpenCV 4.6): the box it returns spans (0, 0) - (16.75,
// 11.25) model units, patches of 2.5 units on a pitch of 2.75, patch k (row r = k / 6, column
// c = k % 6) centred at (1.5 + 2.75 c, 1.5 + 2.75 r); box[0] is the corner next to the first
// patch (dark skin, A01), then A06, D06, D01.
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/mcc.hpp>

#include <Eigen/Dense>

#include "paintlab/calibration/colour.h"
#include "paintlab/core/error.h"

namespace paintlab::calib {

namespace {

constexpr double kBoxW = 16.75, kBoxH = 11.25;  // the detector's box, model units
constexpr double kPitch = 2.75, kFirst = 1.5;    // patch pitch, first patch's centre
constexpr double kHalfSample = 0.55;             // half side of the square measured (a patch: 1.25)
constexpr int kCols = 6, kRows = 4;
constexpr double kMinPitchPx = 24.0;

Eigen::Vector2d model_centre(int k) { return {kFirst + kPitch * (k % kCols), kFirst + kPitch * (k / kCols)}; }

Eigen::Vector2d map(const cv::Matx33d& H, const Eigen::Vector2d& m) {
  const cv::Vec3d p = H * cv::Vec3d(m.x(), m.y(), 1.0);
  return {p[0] / p[2], p[1] / p[2]};
}

// 8-bit sRGB-encoded BGR for the detector: the 99.5th percentile of the brightest channel
// goes to white.
cv::Mat tone_mapped(const ImageF& img) {
  std::vector<float> peaks;
  const std::size_t n = static_cast<std::size_t>(img.width()) * img.height();
  const float* d = img.data();
  const std::size_t step = std::max<std::size_t>(1, n / 200000);
  for (std::size_t i = 0; i < n; i += step) peaks.push_back(std::max({d[3 * i], d[3 * i + 1], d[3 * i + 2]}));
  const auto q = peaks.begin() + static_cast<std::ptrdiff_t>(0.995 * static_cast<double>(peaks.size() - 1));
  std::nth_element(peaks.begin(), q, peaks.end());
  const double scale = *q > 0 ? 1.0 / *q : 1.0;
  cv::Mat bgr(img.height(), img.width(), CV_8UC3);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const double v = std::clamp(img.at(x, y, c) * scale, 0.0, 1.0);
        const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;  // IEC 61966-2-1
        bgr.at<cv::Vec3b>(y, x)[2 - c] = static_cast<std::uint8_t>(std::lround(255.0 * e));
      }
  return bgr;
}

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Each patch's central square measured through the model-to-image map H.
std::vector<PatchMeasurement> sample_patches(const ImageF& img, const cv::Matx33d& H, const ChartReference& ref,
                                             double saturation) {
  const cv::Matx33d Hinv = H.inv();
  std::vector<PatchMeasurement> out;
  for (int k = 0; k < kCols * kRows; ++k) {
    const Eigen::Vector2d c = model_centre(k);
    double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
    for (int corner = 0; corner < 4; ++corner) {
      const Eigen::Vector2d p =
          map(H, c + Eigen::Vector2d(corner & 1 ? kHalfSample : -kHalfSample, corner & 2 ? kHalfSample : -kHalfSample));
      x0 = std::min(x0, p.x()), y0 = std::min(y0, p.y()), x1 = std::max(x1, p.x()), y1 = std::max(y1, p.y());
    }
    std::vector<double> values[3];
    PatchMeasurement m;
    m.name = ref.patches[static_cast<std::size_t>(k)];
    for (int y = std::max(0, static_cast<int>(std::ceil(y0))); y <= std::min(img.height() - 1, static_cast<int>(y1)); ++y)
      for (int x = std::max(0, static_cast<int>(std::ceil(x0))); x <= std::min(img.width() - 1, static_cast<int>(x1));
           ++x) {
        const Eigen::Vector2d u = map(Hinv, Eigen::Vector2d(x, y)) - c;
        if (std::abs(u.x()) > kHalfSample || std::abs(u.y()) > kHalfSample) continue;
        for (int ch = 0; ch < 3; ++ch) {
          const double v = img.at(x, y, ch);
          values[ch].push_back(v);
          if (v >= saturation) m.clipped = true;
        }
      }
    if (values[0].size() < 9) {
      m.rgb = colour::Rgb::Constant(std::nan(""));
      out.push_back(m);
      continue;
    }
    double med[3], mad[3];
    for (int ch = 0; ch < 3; ++ch) {
      med[ch] = median(values[ch]);
      std::vector<double> dev;
      for (double v : values[ch]) dev.push_back(std::abs(v - med[ch]));
      mad[ch] = std::max(median(dev), 1e-12 * std::abs(med[ch]) + 1e-30);
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
    long long n = 0;
    for (std::size_t i = 0; i < values[0].size(); ++i) {
      bool keep = true;
      for (int ch = 0; ch < 3; ++ch) keep = keep && std::abs(values[ch][i] - med[ch]) <= 4.0 * 1.4826 * mad[ch];
      if (!keep) continue;
      for (int ch = 0; ch < 3; ++ch) {
        sum[ch] += values[ch][i];
        sum2[ch] += values[ch][i] * values[ch][i];
      }
      ++n;
    }
    m.pixels = n;
    m.rgb = sum / static_cast<double>(n);
    const Eigen::Vector3d var = (sum2 / static_cast<double>(n) - m.rgb.cwiseProduct(m.rgb)).cwiseMax(0.0);
    m.stderr_rgb = (var / static_cast<double>(std::max<long long>(n - 1, 1))).cwiseSqrt();
    out.push_back(m);
  }
  return out;
}

// How badly an affine colour map explains the patches (relative residual): small for the
// right orientation, large for a wrong one whatever the camera's colours and exposure.
double affine_misfit(const std::vector<PatchMeasurement>& patches, const std::vector<colour::Xyz>& xyz) {
  Eigen::MatrixXd A(static_cast<Eigen::Index>(patches.size()), 4), B(static_cast<Eigen::Index>(patches.size()), 3);
  for (std::size_t i = 0; i < patches.size(); ++i) {
    if (!patches[i].rgb.allFinite()) return std::numeric_limits<double>::infinity();
    A.row(static_cast<Eigen::Index>(i)) << patches[i].rgb.transpose(), 1.0;
    B.row(static_cast<Eigen::Index>(i)) = xyz[i].transpose();
  }
  // Scale-free: the camera's values in units of their largest.
  A.leftCols<3>() /= std::max(A.leftCols<3>().cwiseAbs().maxCoeff(), 1e-300);
  const Eigen::MatrixXd X = A.colPivHouseholderQr().solve(B);
  return (A * X - B).squaredNorm() / B.squaredNorm();
}

}  // namespace

ChartDetection find_colour_chart(const ImageF& linear_rgb, const ChartReference& reference, double saturation) {
  if (linear_rgb.channels() != 3)
    throw DataError(fmt::format("colour chart: the image has {} channel(s); the chart needs colour (3)",
                                linear_rgb.channels()));
  if (reference.patches.size() != static_cast<std::size_t>(kCols * kRows))
    throw DataError(fmt::format("colour chart: the chart finder knows the ColorChecker 24 layout; {} has {} patches",
                                reference.source, reference.patches.size()));
  cv::Ptr<cv::mcc::CCheckerDetector> detector = cv::mcc::CCheckerDetector::create();
  if (!detector->process(tone_mapped(linear_rgb), cv::mcc::MCC24, 1))
    throw CalibrationError(fmt::format(
        "colour chart: no ColorChecker 24 found in the {}x{} image (the whole chart with its black border must be "
        "in view, lit evenly, not clipped)",
        linear_rgb.width(), linear_rgb.height()));
  const std::vector<cv::Point2f> box = detector->getBestColorChecker()->getBox();
  if (box.size() != 4) throw CalibrationError("colour chart: the detector returned a box without four corners");

  // The orderings of the box a 6 x 4 grid allows: as found, turned half way, and the two mirrors.
  const int orders[4][4] = {{0, 1, 2, 3}, {2, 3, 0, 1}, {1, 0, 3, 2}, {3, 2, 1, 0}};
  const std::vector<cv::Point2f> model = {{0.0f, 0.0f},
                                          {static_cast<float>(kBoxW), 0.0f},
                                          {static_cast<float>(kBoxW), static_cast<float>(kBoxH)},
                                          {0.0f, static_cast<float>(kBoxH)}};
  const std::vector<colour::Xyz> xyz = reference.xyz_d65();
  double best = std::numeric_limits<double>::infinity(), second = best;
  ChartDetection out;
  for (const auto& order : orders) {
    std::vector<cv::Point2f> corners;
    for (int i : order) corners.push_back(box[static_cast<std::size_t>(i)]);
    const cv::Matx33d H = cv::getPerspectiveTransform(model, corners);
    const double pitch = (map(H, model_centre(8) + Eigen::Vector2d(kPitch, 0)) - map(H, model_centre(8))).norm();
    if (pitch < kMinPitchPx)
      throw CalibrationError(fmt::format("colour chart: the patches are {:.0f} px apart; at least {:.0f} px are needed "
                                         "(bring the chart closer or zoom in)",
                                         pitch, kMinPitchPx));
    std::vector<PatchMeasurement> patches = sample_patches(linear_rgb, H, reference, saturation);
    const double misfit = affine_misfit(patches, xyz);
    if (misfit < best) {
      second = best;
      best = misfit;
      out.patches = std::move(patches);
      out.pitch_px = pitch;
      for (int i = 0; i < 4; ++i) out.corners[static_cast<std::size_t>(i)] = Eigen::Vector2d(corners[static_cast<std::size_t>(i)].x, corners[static_cast<std::size_t>(i)].y);
      out.centres.clear();
      for (int k = 0; k < kCols * kRows; ++k) out.centres.push_back(map(H, model_centre(k)));
    } else {
      second = std::min(second, misfit);
    }
  }
  out.orientation_margin = second / std::max(best, 1e-300);
  if (!std::isfinite(best) || out.orientation_margin < 3.0)
    throw CalibrationError(fmt::format(
        "colour chart: the chart's orientation is ambiguous (the best two orientations fit within a factor {:.1f}); is "
        "it a ColorChecker 24 matching the reference {}?",
        out.orientation_margin, reference.source));
  return out;
}

}  // namespace paintlab::calib
