#include "paintlab/fitting/prefiltered_env.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>

#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"

namespace paintlab::fit {
namespace fs = std::filesystem;
using brdf::Rgb;
using brdf::Vec3;

namespace prefiltered_detail {

constexpr double kPiEnv = std::numbers::pi;
// A lobe's tail below this fraction of its peak is left out of the sum.
constexpr double kLobeCut = 1e-4;
// Written into the cache key: a change of how maps are built invalidates old caches.
constexpr int kPrefilterVersion = 1;

// The map `src` box-filtered to height h (and width 2h); h divides nothing in general, so each
// output texel averages the source texels whose centres fall into it.
ImageF downsample(const ImageF& src, int h) {
  const int W = src.width(), H = src.height();
  if (h >= H) return src;
  const int w = 2 * h;
  ImageF out(w, h, 3, 0.0f);
  std::vector<double> sum(static_cast<std::size_t>(w) * h * 3, 0.0), weight(static_cast<std::size_t>(w) * h, 0.0);
  for (int y = 0; y < H; ++y) {
    const int oy = std::min(h - 1, static_cast<int>((y + 0.5) * h / H));
    // Solid angle of a source texel of this row (relative): sin(theta).
    const double sa = std::sin(kPiEnv * (y + 0.5) / H);
    for (int x = 0; x < W; ++x) {
      const int ox = std::min(w - 1, static_cast<int>((x + 0.5) * w / W));
      const std::size_t o = static_cast<std::size_t>(oy) * w + ox;
      weight[o] += sa;
      for (int c = 0; c < 3; ++c) sum[3 * o + c] += sa * src.at(x, y, c);
    }
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t o = static_cast<std::size_t>(y) * w + x;
      for (int c = 0; c < 3; ++c)
        out.at(x, y, c) = weight[o] > 0 ? static_cast<float>(sum[3 * o + c] / weight[o]) : 0.0f;
    }
  return out;
}

Vec3 direction_of(double u, double v) {
  const double phi = 2 * kPiEnv * (u - 0.5), theta = kPiEnv * v;
  return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

// P_E over every texel centre of an output map of height h, from the source `src`.
ImageF prefilter(const ImageF& full, double E, int max_height) {
  const int h = std::clamp(static_cast<int>(std::ceil(2 * kPiEnv * std::sqrt(E))), 16, std::max(16, max_height));
  const ImageF src = downsample(full, std::min(full.height(), 2 * h));
  const int W = src.width(), H = src.height(), w = 2 * h;
  // The source texels: directions, solid angles.
  std::vector<double> row_theta(static_cast<std::size_t>(H)), row_solid(static_cast<std::size_t>(H));
  for (int y = 0; y < H; ++y) {
    row_theta[static_cast<std::size_t>(y)] = kPiEnv * (y + 0.5) / H;
    row_solid[static_cast<std::size_t>(y)] = (2 * kPiEnv / W) * (std::cos(kPiEnv * y / H) - std::cos(kPiEnv * (y + 1) / H));
  }
  std::vector<Vec3> dirs(static_cast<std::size_t>(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) dirs[static_cast<std::size_t>(y) * W + x] = direction_of((x + 0.5) / W, (y + 0.5) / H);
  // Where (d.w)^E falls below the cut: cos(alpha_max) = cut^(1/E) (the whole hemisphere when
  // that is below 0).
  const double c_min = std::max(0.0, std::pow(kLobeCut, 1.0 / E));
  const double alpha_max = std::acos(c_min);
  ImageF out(w, h, 3, 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int oy = rows.begin(); oy < rows.end(); ++oy) {
      const double theta_d = kPiEnv * (oy + 0.5) / h;
      const int y0 = std::max(0, static_cast<int>(std::floor((theta_d - alpha_max) / kPiEnv * H)));
      const int y1 = std::min(H - 1, static_cast<int>(std::ceil((theta_d + alpha_max) / kPiEnv * H)));
      for (int ox = 0; ox < w; ++ox) {
        const double u = (ox + 0.5) / w;
        const Vec3 d = direction_of(u, (oy + 0.5) / h);
        Rgb sum = Rgb::Zero();
        double weight = 0;
        for (int y = y0; y <= y1; ++y) {
          const double th = row_theta[static_cast<std::size_t>(y)];
          // The azimuth span of this row inside the lobe's cone: cos(alpha) = cos th cos td +
          // sin th sin td cos(dphi) >= c_min.
          const double s = std::sin(th) * std::sin(theta_d);
          int half = W / 2 + 1;  // every column
          if (s > 1e-12) {
            const double cdp = (c_min - std::cos(th) * std::cos(theta_d)) / s;
            if (cdp > 1) continue;
            if (cdp > -1) half = std::min(half, static_cast<int>(std::ceil(std::acos(cdp) / (2 * kPiEnv) * W)) + 1);
          }
          const int xc = static_cast<int>(std::floor(u * W));
          const int first = half >= W / 2 ? 0 : xc - half, last = half >= W / 2 ? W - 1 : xc + half;
          for (int xx = first; xx <= last; ++xx) {
            const int x = ((xx % W) + W) % W;
            const double c = d.dot(dirs[static_cast<std::size_t>(y) * W + x]);
            if (c <= c_min || c <= 0) continue;
            const double k = std::pow(c, E) * row_solid[static_cast<std::size_t>(y)];
            weight += k;
            for (int ch = 0; ch < 3; ++ch) sum[ch] += k * src.at(x, y, ch);
          }
        }
        // The kernel normalised to its exact integral over the sphere, 2 pi / (E + 1): a lobe a
        // few source texels wide is summed over few texels, whose weights do not add up to it.
        const double norm = weight > 0 ? 2 * kPiEnv / (E + 1) / weight : 0.0;
        for (int ch = 0; ch < 3; ++ch) out.at(ox, oy, ch) = static_cast<float>(sum[ch] * norm);
      }
    }
  });
  return out;
}

std::string cache_key(const fs::path& exr, double intensity, const std::vector<double>& exponents) {
  std::string text = fmt::format("v{} {} {:.17g}", kPrefilterVersion, sha256_file(exr), intensity);
  for (double e : exponents) text += fmt::format(" {:.17g}", e);
  return sha256_hex(text).substr(0, 32);
}

ImageF read_map(const fs::path& file) {
  const ExrImage img = read_exr(file);
  ImageF out(img.width, img.height, 3);
  for (int c = 0; c < 3; ++c) {
    const ImageF& p = img.plane(std::string(1, "RGB"[c]));
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) out.at(x, y, c) = p.at(x, y);
  }
  return out;
}

}  // namespace prefiltered_detail
using namespace prefiltered_detail;

void PrefilteredEnvironment::uv_of(const Vec3& d, double* u, double* v) {
  *u = std::atan2(d.x(), -d.z()) / (2 * kPiEnv) + 0.5;
  *v = std::acos(std::clamp(d.y(), -1.0, 1.0)) / kPiEnv;
}

Rgb PrefilteredEnvironment::lookup_uv(const ImageF& map, double u, double v) {
  const int W = map.width(), H = map.height();
  const double fx = u * W - 0.5, fy = v * H - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const float ax = static_cast<float>(fx - x0), ay = static_cast<float>(fy - y0);
  const int xa = ((x0 % W) + W) % W, xb = (xa + 1) % W;
  const int ya = std::clamp(y0, 0, H - 1), yb = std::clamp(y0 + 1, 0, H - 1);
  const float* a0 = &map.at(xa, ya, 0);
  const float* a1 = &map.at(xb, ya, 0);
  const float* b0 = &map.at(xa, yb, 0);
  const float* b1 = &map.at(xb, yb, 0);
  Rgb out;
  for (int c = 0; c < 3; ++c)
    out[c] = (1 - ay) * ((1 - ax) * a0[c] + ax * a1[c]) + ay * ((1 - ax) * b0[c] + ax * b1[c]);
  return out;
}

Rgb PrefilteredEnvironment::lookup(const ImageF& map, const Vec3& d) {
  double u, v;
  uv_of(d, &u, &v);
  return lookup_uv(map, u, v);
}

PrefilteredEnvironment PrefilteredEnvironment::build(const EnvironmentMap& env, const std::vector<double>& exponents) {
  PrefilteredEnvironment p;
  p.exponents_ = exponents;
  p.maps_.push_back(prefilter(env.rgb(), 1.0, env.height()));
  for (double e : exponents) p.maps_.push_back(prefilter(env.rgb(), e, env.height()));
  return p;
}

fs::path PrefilteredEnvironment::default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "paintlab" / "prefiltered";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "paintlab" / "prefiltered";
  return fs::temp_directory_path() / "paintlab-prefiltered";
}

PrefilteredEnvironment PrefilteredEnvironment::cached(const fs::path& exr, double intensity,
                                                      const std::vector<double>& exponents, const fs::path& cache_dir,
                                                      bool* from_cache) {
  const fs::path dir = cache_dir / cache_key(exr, intensity, exponents);
  const std::size_t count = exponents.size() + 1;
  auto file = [&](std::size_t k) { return dir / fmt::format("map{:02d}.exr", k); };
  std::error_code ec;
  bool all = true;
  for (std::size_t k = 0; k < count && all; ++k) all = fs::is_regular_file(file(k), ec);
  if (all) {
    try {
      PrefilteredEnvironment p;
      p.exponents_ = exponents;
      for (std::size_t k = 0; k < count; ++k) p.maps_.push_back(read_map(file(k)));
      if (from_cache) *from_cache = true;
      return p;
    } catch (const Error& e) {  // a damaged cache entry is rebuilt
      spdlog::warn("prefiltered map cache {}: {} (rebuilding)", dir.string(), e.what());
    }
  }
  PrefilteredEnvironment p = build(EnvironmentMap::load(exr, intensity), exponents);
  if (from_cache) *from_cache = false;
  try {
    fs::create_directories(dir);
    for (std::size_t k = 0; k < count; ++k)
      write_exr_rgb(file(k), p.maps_[k],
                    k == 0 ? "paintlab prefiltered irradiance (E = 1)"
                           : fmt::format("paintlab prefiltered map, exponent {:.17g}", exponents[k - 1]));
  } catch (const std::exception& e) {
    spdlog::warn("prefiltered maps not cached in {}: {}", dir.string(), e.what());
  }
  return p;
}

Preview render_preview_cosine(const brdf::CosineLobeParams& paint, const PreviewOptions& o,
                              const PrefilteredEnvironment* env) {
  o.check();
  if (const std::string problem = brdf::cosine_lobes_problem(paint); !problem.empty())
    throw DataError("cosine-lobe paint: " + problem);
  if (env && env->exponents() != paint.exponents)
    throw DataError(fmt::format("the prefiltered maps hold {} exponents other than the paint's {}",
                                env->exponents().size(), paint.exponents.size()));
  const brdf::CosineLobes model(paint);
  const int S = o.size_px;
  Preview out;
  out.linear = ImageF(S, S, 3, 0.0f);
  out.mask.assign(static_cast<std::size_t>(S) * S, 0);
  const Vec3 wo = Vec3::UnitZ();
  tbb::parallel_for(tbb::blocked_range<int>(0, S), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < S; ++x) {
        Vec3 n, wi;
        double r = 0;
        if (!preview_geometry(o, x, y, &n, &wi, &r)) continue;
        out.mask[static_cast<std::size_t>(y) * S + x] = 1;
        Rgb v = Rgb::Zero();
        const double nv = n.dot(wo);
        if (o.point_light && n.dot(wi) > 0)
          v += eval_world(model, n, wi, wo) * n.dot(wi) * (o.light_distance / r) * (o.light_distance / r);
        if (env) {
          const Vec3 rv = 2 * nv * n - wo;
          v += paint.kd / kPiEnv * env->irradiance(n);
          double u = 0, w = 0;
          PrefilteredEnvironment::uv_of(rv, &u, &w);
          for (std::size_t i = 0; i < paint.exponents.size(); ++i)
            v += (paint.kg[i] + nv * paint.kdd[i]) * PrefilteredEnvironment::lookup_uv(env->map(i + 1), u, w);
        }
        for (int c = 0; c < 3; ++c) out.linear.at(x, y, c) = static_cast<float>(v[c]);
      }
  });
  finish_preview(out, o);
  return out;
}

}  // namespace paintlab::fit
