#include "paintlab/sim/camera_model.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "parallel.h"

namespace paintlab::sim {

CameraModel::CameraModel(const CameraTruth& truth)
    : truth_(truth), cam_from_rig_(truth.cam_from_rig()), rig_from_cam_(cam_from_rig_.inverse()) {}

Vec2 CameraModel::distort(const Vec2& xn) const {
  const auto& d = truth_.dist;
  double x = xn.x(), y = xn.y();
  double r2 = x * x + y * y;
  double radial = 1.0 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  return {x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x),
          y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y};
}

Vec2 CameraModel::undistort(const Vec2& xd) const {
  const auto& d = truth_.dist;
  Vec2 x = xd;
  for (int it = 0; it < 50; ++it) {
    double u = x.x(), v = x.y();
    double r2 = u * u + v * v;
    double radial = 1.0 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
    double dradial = d[0] + r2 * (2.0 * d[1] + 3.0 * r2 * d[4]);  // d radial / d r2
    Vec2 f = distort(x) - xd;
    // Jacobian of distort().
    double j00 = radial + 2.0 * u * u * dradial + 2.0 * d[2] * v + 6.0 * d[3] * u;
    double j01 = 2.0 * u * v * dradial + 2.0 * d[2] * u + 2.0 * d[3] * v;
    double j10 = 2.0 * u * v * dradial + 2.0 * d[2] * u + 2.0 * d[3] * v;
    double j11 = radial + 2.0 * v * v * dradial + 6.0 * d[2] * v + 2.0 * d[3] * u;
    double det = j00 * j11 - j01 * j10;
    if (std::abs(det) < 1e-12) break;
    Vec2 step((j11 * f.x() - j01 * f.y()) / det, (-j10 * f.x() + j00 * f.y()) / det);
    x -= step;
    if (step.squaredNorm() < 1e-30) break;
  }
  return x;
}

Vec2 CameraModel::project(const Vec3& p) const {
  Vec2 xd = distort(Vec2(p.x() / p.z(), p.y() / p.z()));
  return {truth_.fx_px * xd.x() + truth_.cx_px, truth_.fy_px * xd.y() + truth_.cy_px};
}

Vec2 CameraModel::unproject(const Vec2& pixel) const {
  return undistort(Vec2((pixel.x() - truth_.cx_px) / truth_.fx_px, (pixel.y() - truth_.cy_px) / truth_.fy_px));
}

Vec3 CameraModel::ray_cam(const Vec2& pixel) const {
  Vec2 xn = unproject(pixel);
  return Vec3(xn.x(), xn.y(), 1.0).normalized();
}

double CameraModel::vignetting(const Vec2& pixel) const {
  Vec2 xn = unproject(pixel);
  double cos2 = 1.0 / (1.0 + xn.squaredNorm());
  double half_diag2 = 0.25 * (static_cast<double>(truth_.width_px) * truth_.width_px +
                              static_cast<double>(truth_.height_px) * truth_.height_px);
  double rho2 = (pixel - Vec2(truth_.cx_px, truth_.cy_px)).squaredNorm() / half_diag2;
  return cos2 * cos2 * (1.0 + truth_.vignetting[0] * rho2 + truth_.vignetting[1] * rho2 * rho2);
}

double CameraModel::irradiance_per_radiance() const {
  return kPi / (4.0 * truth_.f_number * truth_.f_number);
}

void CameraModel::blur(ImageF& image, int threads) const {
  double sigma = truth_.psf_sigma_px;
  if (!(sigma > 0)) return;
  int radius = std::max(1, static_cast<int>(std::ceil(4.0 * sigma)));
  std::vector<float> taps(static_cast<std::size_t>(2 * radius + 1));
  double sum = 0;
  for (int k = -radius; k <= radius; ++k) sum += taps[static_cast<std::size_t>(k + radius)] = static_cast<float>(std::exp(-0.5 * k * k / (sigma * sigma)));
  for (float& t : taps) t = static_cast<float>(t / sum);
  const int w = image.width(), h = image.height(), ch = image.channels();
  const int n = 2 * radius + 1;
  ImageF tmp(w, h, ch);
  // Horizontal pass into tmp (clamped taps only near the left and right borders), then a
  // vertical pass back into the image over whole rows (clamped row pointers).
  detail::parallel_rows(h, threads, [&](int y) {
    const float* in = image.row(y);
    float* out = tmp.row(y);
    for (int x = 0; x < w; ++x) {
      bool inside = x >= radius && x + radius < w;
      for (int c = 0; c < ch; ++c) {
        float acc = 0;
        if (inside) {
          const float* src = in + (x - radius) * ch + c;
          for (int k = 0; k < n; ++k) acc += taps[static_cast<std::size_t>(k)] * src[k * ch];
        } else {
          for (int k = 0; k < n; ++k) acc += taps[static_cast<std::size_t>(k)] * in[std::clamp(x + k - radius, 0, w - 1) * ch + c];
        }
        out[x * ch + c] = acc;
      }
    }
  });
  detail::parallel_rows(h, threads, [&](int y) {
    std::vector<const float*> rows(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) rows[static_cast<std::size_t>(k)] = tmp.row(std::clamp(y + k - radius, 0, h - 1));
    float* out = image.row(y);
    const int len = w * ch;
    for (int i = 0; i < len; ++i) out[i] = 0;
    for (int k = 0; k < n; ++k) {
      const float t = taps[static_cast<std::size_t>(k)];
      const float* src = rows[static_cast<std::size_t>(k)];
      for (int i = 0; i < len; ++i) out[i] += t * src[i];
    }
  });
}

const std::vector<Vec2>& CameraModel::corner_grid() const {
  std::call_once(corners_once_, [this] {
    int w = truth_.width_px + 1, h = truth_.height_px + 1;
    corners_.resize(static_cast<std::size_t>(w) * h);
    tbb::parallel_for(0, h, [&](int j) {
      for (int i = 0; i < w; ++i) corners_[static_cast<std::size_t>(j) * w + i] = unproject(Vec2(i - 0.5, j - 0.5));
    });
  });
  return corners_;
}

Vec2 CameraModel::grid_point(int px, int py, double fx, double fy) const {
  const auto& g = corner_grid();
  std::size_t w = static_cast<std::size_t>(truth_.width_px) + 1;
  std::size_t i00 = static_cast<std::size_t>(py) * w + px;
  const Vec2& a = g[i00];
  const Vec2& b = g[i00 + 1];
  const Vec2& c = g[i00 + w];
  const Vec2& d = g[i00 + w + 1];
  return (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d);
}

}  // namespace paintlab::sim
