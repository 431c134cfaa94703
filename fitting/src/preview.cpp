#include "paintlab/fitting/preview.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/robust.h"

namespace paintlab::fit {

using brdf::Rgb;
using brdf::Vec3;

namespace {

constexpr double kPiD = std::numbers::pi;

double luminance(const Rgb& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

// A small counter-based generator (SplitMix64): every pixel gets its own stream from
// (seed, x, y), so images are identical whatever the thread count.
struct PixelRng {
  std::uint64_t state;
  PixelRng(std::uint64_t seed, int x, int y)
      : state(seed * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(x) << 32) ^ static_cast<std::uint64_t>(y)) {}
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

// Unit vector about `axis` at polar cosine c and azimuth phi.
Vec3 around(const Vec3& axis, double c, double phi) {
  const Mat3 f = frame_from_normal(axis);
  const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
  return f * Vec3(s * std::cos(phi), s * std::sin(phi), c);
}

struct Cone {
  Vec3 axis;
  double cos_alpha;
  double pdf_inside;
  Cone(const Vec3& a, double alpha_rad) : axis(a), cos_alpha(std::cos(alpha_rad)) {
    pdf_inside = 1.0 / (2 * kPiD * (1 - cos_alpha));
  }
  Vec3 sample(double u1, double u2) const { return around(axis, 1 - u1 * (1 - cos_alpha), 2 * kPiD * u2); }
  double pdf(const Vec3& d) const { return d.dot(axis) >= cos_alpha ? pdf_inside : 0.0; }
};

}  // namespace

Rgb eval_world(const brdf::Brdf& brdf, const Vec3& n, const Vec3& wi, const Vec3& wo) {
  const Mat3 f = frame_from_normal(n);
  return brdf.eval(f.transpose() * wi, f.transpose() * wo);
}

std::uint8_t srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
  return static_cast<std::uint8_t>(std::lround(std::clamp(e, 0.0, 1.0) * 255.0));
}

double auto_exposure(const ImageF& rgb, const std::vector<std::uint8_t>& mask, double percentile) {
  std::vector<float> v;
  v.reserve(rgb.pixel_count());
  for (int y = 0; y < rgb.height(); ++y)
    for (int x = 0; x < rgb.width(); ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * rgb.width() + x;
      if (!mask.empty() && !mask[i]) continue;
      float m = 0;
      for (int c = 0; c < rgb.channels(); ++c) m = std::max(m, rgb.at(x, y, c));
      if (std::isfinite(m)) v.push_back(m);
    }
  if (v.empty()) return 1.0;
  const double top = lower_quantile_inplace(v, std::clamp(percentile / 100.0, 0.0, 1.0));
  return top > 0 ? 1.0 / top : 1.0;
}

ImageU8 tone_map(const ImageF& rgb, double exposure) {
  // srgb_encode by table: the linear value where each 8-bit code begins (the curve's inverse at
  // (k - 0.5) / 255), each checked against srgb_encode so the codes are exactly its own; a
  // binary search instead of a pow per value (a 512 x 512 preview: 25 ms -> 3 ms).
  static const std::array<double, 256> starts = [] {
    std::array<double, 256> t{};
    t[0] = -INFINITY;
    for (int k = 1; k < 256; ++k) {
      const double e = (k - 0.5) / 255.0;
      double lin = e <= 12.92 * 0.0031308 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
      // Nudge onto srgb_encode's own boundary (rounding of the pow and of lround).
      while (srgb_encode(lin) >= k) lin = std::nextafter(lin, -INFINITY);
      while (srgb_encode(lin) < k) lin = std::nextafter(lin, INFINITY);
      t[static_cast<std::size_t>(k)] = lin;
    }
    return t;
  }();
  ImageU8 out(rgb.width(), rgb.height(), rgb.channels());
  const std::size_t n = rgb.size();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const double v = exposure * rgb.values()[i];
      if (!(v == v)) {  // NaN: as srgb_encode (clamp keeps it, the cast of lround(NaN))
        out.values()[i] = srgb_encode(v);
        continue;
      }
      out.values()[i] = static_cast<std::uint8_t>(std::upper_bound(starts.begin(), starts.end(), v) - starts.begin() - 1);
    }
  });
  return out;
}

// ---- environment map ----

EnvironmentMap EnvironmentMap::load(const std::filesystem::path& exr, double intensity) {
  const ExrImage img = read_exr(exr);
  ImageF rgb(img.width, img.height, 3);
  const bool has_rgb = img.find("R") && img.find("G") && img.find("B");
  if (!has_rgb && !img.find("Y"))
    throw DataError(exr.string() + ": an environment map needs channels R, G, B (or Y)");
  for (int c = 0; c < 3; ++c) {
    const ImageF& plane = has_rgb ? img.plane(c == 0 ? "R" : c == 1 ? "G" : "B") : img.plane("Y");
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const float v = plane.at(x, y);
        if (!std::isfinite(v) || v < 0)
          throw DataError(exr.string() + fmt::format(": pixel ({}, {}) channel {} is {} (radiance must be finite and >= 0)",
                                                     x, y, "RGB"[c], v));
        rgb.at(x, y, c) = v;
      }
  }
  if (img.width != 2 * img.height)
    throw DataError(exr.string() + fmt::format(": an equirectangular map is twice as wide as high (got {} x {})",
                                               img.width, img.height));
  return EnvironmentMap(std::move(rgb), intensity);
}

EnvironmentMap::EnvironmentMap(ImageF rgb, double intensity) : rgb_(std::move(rgb)) {
  const int W = rgb_.width(), H = rgb_.height();
  if (W < 2 || H < 1 || rgb_.channels() != 3) throw DataError("environment map: needs at least 2 x 1 RGB texels");
  for (float& v : rgb_.values()) v = static_cast<float>(v * intensity);
  texel_p_.assign(static_cast<std::size_t>(W) * H, 0.0);
  row_cdf_.assign(static_cast<std::size_t>(H) + 1, 0.0);
  col_cdf_.assign(static_cast<std::size_t>(H) * (W + 1), 0.0);
  double total = 0;
  for (int y = 0; y < H; ++y) {
    const double solid = (2 * kPiD / W) * (std::cos(kPiD * y / H) - std::cos(kPiD * (y + 1) / H));
    double* cdf = &col_cdf_[static_cast<std::size_t>(y) * (W + 1)];
    for (int x = 0; x < W; ++x) {
      const double w = luminance(Rgb(rgb_.at(x, y, 0), rgb_.at(x, y, 1), rgb_.at(x, y, 2))) * solid;
      texel_p_[static_cast<std::size_t>(y) * W + x] = w;
      cdf[x + 1] = cdf[x] + w;
    }
    row_cdf_[static_cast<std::size_t>(y) + 1] = row_cdf_[static_cast<std::size_t>(y)] + cdf[W];
    total += cdf[W];
  }
  if (total > 0)
    for (double& p : texel_p_) p /= total;
}

Vec3 EnvironmentMap::direction(double u, double v) const {
  const double phi = 2 * kPiD * (u - 0.5), theta = kPiD * v;
  return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

void EnvironmentMap::texel_of(const Vec3& d, int* x, int* y) const {
  const double theta = std::acos(std::clamp(d.y(), -1.0, 1.0));
  const double phi = std::atan2(d.x(), -d.z());  // (-pi, pi], 0 at -z
  const double u = phi / (2 * kPiD) + 0.5, v = theta / kPiD;
  *x = std::clamp(static_cast<int>(u * width()), 0, width() - 1);
  *y = std::clamp(static_cast<int>(v * height()), 0, height() - 1);
}

Rgb EnvironmentMap::radiance(const Vec3& d) const {
  int x, y;
  texel_of(d, &x, &y);
  return {rgb_.at(x, y, 0), rgb_.at(x, y, 1), rgb_.at(x, y, 2)};
}

double EnvironmentMap::pdf(const Vec3& d) const {
  int x, y;
  texel_of(d, &x, &y);
  const double p = texel_p_[static_cast<std::size_t>(y) * width() + x];
  if (p <= 0) return 0;
  const double solid = (2 * kPiD / width()) * (std::cos(kPiD * y / height()) - std::cos(kPiD * (y + 1) / height()));
  return p / solid;
}

Vec3 EnvironmentMap::sample(double u1, double u2, double* pdf_out) const {
  const int W = width(), H = height();
  const double total = row_cdf_.back();
  if (!(total > 0)) {
    *pdf_out = 0;
    return Vec3::UnitY();
  }
  // Row, then column within the row, by their CDFs; then uniform in solid angle in the texel.
  const double t = u1 * total;
  int y = static_cast<int>(std::upper_bound(row_cdf_.begin(), row_cdf_.end(), t) - row_cdf_.begin()) - 1;
  y = std::clamp(y, 0, H - 1);
  const double row_w = row_cdf_[static_cast<std::size_t>(y) + 1] - row_cdf_[static_cast<std::size_t>(y)];
  const double r = std::clamp((t - row_cdf_[static_cast<std::size_t>(y)]) / row_w, 0.0, 1.0);
  const double* cdf = &col_cdf_[static_cast<std::size_t>(y) * (W + 1)];
  const double tc = r * cdf[W];
  int x = static_cast<int>(std::upper_bound(cdf, cdf + W + 1, tc) - cdf) - 1;
  x = std::clamp(x, 0, W - 1);
  while (x > 0 && texel_p_[static_cast<std::size_t>(y) * W + x] <= 0) --x;  // t landed on a zero-width step
  const double cw = cdf[x + 1] - cdf[x];
  const double s = cw > 0 ? std::clamp((tc - cdf[x]) / cw, 0.0, 1.0) : 0.5;
  const double c0 = std::cos(kPiD * y / H), c1 = std::cos(kPiD * (y + 1) / H);
  const double ct = c0 + u2 * (c1 - c0);
  const double theta = std::acos(std::clamp(ct, -1.0, 1.0));
  const double u = (x + s) / W;
  const Vec3 d = direction(u, theta / kPiD);
  const double solid = (2 * kPiD / W) * (c0 - c1);
  *pdf_out = texel_p_[static_cast<std::size_t>(y) * W + x] / solid;
  return d;
}

// ---- preview ----

void PreviewOptions::check() const {
  auto fail = [](const char* field, double value, const char* rule) {
    throw OptionError(std::string("PreviewOptions::") + field, fmt::format("{}", value), rule);
  };
  if (size_px < 16 || size_px > 8192) fail("size_px", size_px, "16..8192");
  if (!(light_azimuth_deg > -180 && light_azimuth_deg <= 180)) fail("light_azimuth_deg", light_azimuth_deg, "(-180, 180]");
  if (!(light_elevation_deg >= -89 && light_elevation_deg <= 89))
    fail("light_elevation_deg", light_elevation_deg, "[-89, 89]");
  if (!(light_distance > 1.5)) fail("light_distance", light_distance, "> 1.5");
  if (!(environment_intensity > 0)) fail("environment_intensity", environment_intensity, "> 0");
  if (environment_samples < 1 || environment_samples > 4096) fail("environment_samples", environment_samples, "1..4096");
  if (!(tone.percentile > 0 && tone.percentile <= 100)) fail("tone.percentile", tone.percentile, "(0, 100]");
}

namespace {
constexpr double kFrameMargin = 1.05;  // the sphere fills 1/1.05 of the image width

Vec3 light_position(const PreviewOptions& o) {
  const double az = deg_to_rad(o.light_azimuth_deg), el = deg_to_rad(o.light_elevation_deg);
  return o.light_distance * Vec3(std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az));
}
}  // namespace

bool preview_geometry(const PreviewOptions& o, int x, int y, Vec3* normal, Vec3* to_light, double* light_distance) {
  const double s = o.size_px;
  const double wx = ((x + 0.5) / s * 2 - 1) * kFrameMargin, wy = (1 - (y + 0.5) / s * 2) * kFrameMargin;
  const double r2 = wx * wx + wy * wy;
  if (r2 >= 1) return false;
  const Vec3 p(wx, wy, std::sqrt(1 - r2));
  *normal = p;
  const Vec3 d = light_position(o) - p;
  *light_distance = d.norm();
  *to_light = d / *light_distance;
  return true;
}

Preview render_preview(const brdf::Brdf& brdf, const PreviewOptions& o, const EnvironmentMap* env_in,
                       const FlakeSparkle* sparkle) {
  o.check();
  std::optional<EnvironmentMap> loaded;
  const EnvironmentMap* env = env_in;
  if (!env && o.environment) {
    loaded = EnvironmentMap::load(*o.environment, o.environment_intensity);
    env = &*loaded;
  }
  const int S = o.size_px;
  Preview out;
  out.linear = ImageF(S, S, 3, 0.0f);
  out.mask.assign(static_cast<std::size_t>(S) * S, 0);
  const Vec3 wo = Vec3::UnitZ();
  const int N = o.environment_samples;
  // Cones around the mirror direction for narrow lobes (clear coat ~1 deg, flakes ~10 deg).
  const double cone_small = deg_to_rad(2.0), cone_large = deg_to_rad(12.0);

  tbb::parallel_for(tbb::blocked_range<int>(0, S), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < S; ++x) {
        Vec3 n, wi;
        double r = 0;
        if (!preview_geometry(o, x, y, &n, &wi, &r)) continue;
        out.mask[static_cast<std::size_t>(y) * S + x] = 1;
        Rgb v = Rgb::Zero();
        if (o.point_light) {
          const double c = n.dot(wi);
          if (c > 0) {
            Rgb f = eval_world(brdf, n, wi, wo);
            if (sparkle) {
              const Mat3 frame = frame_from_normal(n);
              f = (f + sparkle->delta(static_cast<std::uint64_t>(y) * S + static_cast<std::uint64_t>(x),
                                      frame.transpose() * wi, frame.transpose() * wo, f))
                      .max(0.0);
            }
            v += f * c * (o.light_distance / r) * (o.light_distance / r);
          }
        }
        if (env) {
          PixelRng rng(o.seed, x, y);
          const Vec3 mirror = 2 * n.dot(wo) * n - wo;
          const Cone small(mirror, cone_small), large(mirror, cone_large);
          Rgb sum = Rgb::Zero();
          for (int strategy = 0; strategy < 4; ++strategy)
            for (int i = 0; i < N; ++i) {
              const double u1 = rng.uniform(), u2 = rng.uniform();
              Vec3 d;
              double env_pdf = 0;
              switch (strategy) {
                case 0: d = env->sample(u1, u2, &env_pdf); break;
                case 1: d = around(n, std::sqrt(1 - u1), 2 * kPiD * u2); break;  // cosine-weighted
                case 2: d = small.sample(u1, u2); break;
                default: d = large.sample(u1, u2); break;
              }
              const double c = n.dot(d);
              if (!(c > 0)) continue;
              if (strategy != 0) env_pdf = env->pdf(d);
              const double pdfs[4] = {env_pdf, c / kPiD, small.pdf(d), large.pdf(d)};
              const double own = pdfs[strategy];
              if (!(own > 0)) continue;
              const double all = pdfs[0] + pdfs[1] + pdfs[2] + pdfs[3];
              // Balance heuristic with equal sample counts: f L cos / sum of pdfs.
              sum += eval_world(brdf, n, d, wo) * env->radiance(d) * (c / all);
            }
          v += sum / N;
        }
        for (int c = 0; c < 3; ++c) out.linear.at(x, y, c) = static_cast<float>(v[c]);
      }
  });

  finish_preview(out, o);
  return out;
}

ImageF sun_and_sky_map(int height) {
  if (height < 2) throw DataError("sun_and_sky_map: height must be at least 2");
  const int W = 2 * height, H = height;
  ImageF map(W, H, 3);
  const Vec3 sun = Vec3(0.5, 0.6, 0.6).normalized();
  const double sun_cos = std::cos(2.0 * kPiD / 180);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double phi = 2 * kPiD * ((x + 0.5) / W - 0.5), theta = kPiD * (y + 0.5) / H;
      const Vec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
      Rgb v;
      if (d.y() > 0) {
        const double t = 1 - d.y();  // 0 at the zenith, 1 at the horizon
        v = Rgb(0.2, 0.3, 0.6) * (1 - t) + Rgb(0.6, 0.7, 0.9) * t;
      } else {
        v = Rgb(0.12, 0.10, 0.08);
      }
      if (d.dot(sun) >= sun_cos) v = Rgb(1.0, 0.95, 0.85) * 2000.0;
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = static_cast<float>(v[c]);
    }
  return map;
}

void finish_preview(Preview& out, const PreviewOptions& o) {
  const int S = o.size_px;
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      if (!out.mask[static_cast<std::size_t>(y) * S + x]) continue;
      const Rgb v(out.linear.at(x, y, 0), out.linear.at(x, y, 1), out.linear.at(x, y, 2));
      if (v.maxCoeff() > out.peak.maxCoeff()) {
        out.peak = v;
        out.peak_x = x;
        out.peak_y = y;
      }
    }
  out.exposure = o.tone.exposure > 0 ? o.tone.exposure : auto_exposure(out.linear, out.mask, o.tone.percentile);
  out.png = tone_map(out.linear, out.exposure);
  // A grey background, so the silhouette shows where the sphere faces away from the light.
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      if (!out.mask[static_cast<std::size_t>(y) * S + x])
        for (int c = 0; c < 3; ++c) out.png.at(x, y, c) = kPreviewBackground;
}

void write_exr_rgb(const std::filesystem::path& path, const ImageF& rgb, const std::string& description) {
  ExrImage img;
  img.width = rgb.width();
  img.height = rgb.height();
  for (int c = 0; c < 3; ++c) {
    ImageF plane(rgb.width(), rgb.height(), 1);
    for (int y = 0; y < rgb.height(); ++y)
      for (int x = 0; x < rgb.width(); ++x) plane.at(x, y) = rgb.at(x, y, c);
    img.add(std::string(1, "RGB"[c]), std::move(plane));
  }
  img.attributes["paintlab.description"] = description;
  write_exr(path, img);
}

}  // namespace paintlab::fit
