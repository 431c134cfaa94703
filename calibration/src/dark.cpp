#include "paintlab/calibration/dark.h"

#include "map_file.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/robust.h"
#include "paintlab/core/line_fit.h"

namespace fs = std::filesystem;

namespace paintlab::calib {

double DarkFrame::hot_fraction() const {
  const auto n = hot.pixel_count();
  return n == 0 ? 0.0 : static_cast<double>(hot_count) / static_cast<double>(n);
}

void DarkOptions::check() const {
  if (!(hot_sigma > 0.0)) throw UsageError(fmt::format("dark: hot_sigma = {}; must be > 0", hot_sigma));
  if (!(hot_min_dn >= 0.0)) throw UsageError(fmt::format("dark: hot_min_dn = {}; must be >= 0", hot_min_dn));
  if (!(noisy_factor > 1.0)) throw UsageError(fmt::format("dark: noisy_factor = {}; must be > 1", noisy_factor));
}

DarkFrame calibrate_dark(std::span<const StackFrame> frames, int bit_depth, const DarkOptions& options) {
  options.check();
  check_stack(frames, bit_depth, 1);
  const auto& first = *frames[0].pixels;
  const int W = first.width();
  const int H = first.height();
  const int C = first.channels();
  const std::size_t S = first.size();

  // Group the frames by exposure time.
  struct Group {
    double t;
    std::vector<const Image<std::uint16_t>*> images;
  };
  std::vector<Group> groups;
  for (const auto& f : frames) {
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const Group& g) { return std::abs(g.t - f.exposure_s) <= 1e-6 * g.t; });
    if (it == groups.end()) groups.push_back({f.exposure_s, {f.pixels}});
    else it->images.push_back(f.pixels);
  }
  std::sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) { return a.t < b.t; });
  const std::size_t G = groups.size();

  DarkFrame d;
  d.bit_depth = bit_depth;
  d.frame_count = static_cast<int>(frames.size());
  for (const auto& g : groups) d.exposures_s.push_back(g.t);
  d.bias_dn = ImageF(W, H, C);
  d.rate_dn_per_s = ImageF(W, H, C);
  d.hot = ImageU8(W, H, 1);

  // Per group: mean and (with >= 2 frames) variance of every value; pooled variance over groups.
  std::vector<std::vector<float>> mean(G, std::vector<float>(S));
  std::vector<float> pooled_var(S, 0.0f);
  std::vector<float> shortest_var;  // variance at the shortest exposure with >= 2 frames
  int pooled_dof = 0;
  int shortest_group = -1;
  for (std::size_t gi = 0; gi < G; ++gi) {
    const auto& imgs = groups[gi].images;
    const std::size_t n = imgs.size();
    if (n >= 2) {
      pooled_dof += static_cast<int>(n) - 1;
      if (shortest_group < 0) shortest_group = static_cast<int>(gi);
    }
  }
  if (shortest_group >= 0) shortest_var.assign(S, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, S, 16384), [&](const auto& r) {
    for (std::size_t gi = 0; gi < G; ++gi) {
      const auto& imgs = groups[gi].images;
      const double n = static_cast<double>(imgs.size());
      for (std::size_t s = r.begin(); s < r.end(); ++s) {
        double sum = 0.0, sq = 0.0;
        for (const auto* img : imgs) {
          const double v = img->data()[s];
          sum += v;
          sq += v * v;
        }
        const double m = sum / n;
        mean[gi][s] = static_cast<float>(m);
        if (imgs.size() >= 2) {
          const double ss = std::max(0.0, sq - n * m * m);
          pooled_var[s] += static_cast<float>(ss);
          if (static_cast<int>(gi) == shortest_group) shortest_var[s] = static_cast<float>(ss / (n - 1.0));
        }
      }
    }
    for (std::size_t s = r.begin(); s < r.end(); ++s) {
      if (pooled_dof > 0) pooled_var[s] /= static_cast<float>(pooled_dof);
      if (G >= 2) {
        // Weighted least squares line through the group means: level = bias + rate * t.
        WeightedLineFit line;
        for (std::size_t gi = 0; gi < G; ++gi)
          line.add(groups[gi].t, mean[gi][s], static_cast<double>(groups[gi].images.size()));
        d.rate_dn_per_s.data()[s] = static_cast<float>(line.slope());
        d.bias_dn.data()[s] = static_cast<float>(line.intercept());
      } else {
        d.bias_dn.data()[s] = mean[0][s];
        d.rate_dn_per_s.data()[s] = 0.0f;
      }
    }
  });

  // Read noise: median temporal std at the shortest exposure with repeated frames.
  if (shortest_group >= 0) {
    // The mean variance (unbiased, unlike the median of few-frame estimates) over the pixels
    // whose variance is not far above the median (random-telegraph and hot pixels).
    std::vector<float> tmp = shortest_var;
    const double med = upper_median_inplace(tmp);
    double sum = 0.0;
    long long n = 0;
    for (float v : shortest_var)
      if (v <= 9.0 * med + 1.0) {
        sum += v;
        ++n;
      }
    d.read_noise_dn = std::sqrt(sum / static_cast<double>(std::max<long long>(n, 1)));
    d.read_noise_measured = true;
  }

  // Hot pixels: level at the longest exposure far above the median of its channel; noisy
  // pixels: temporal std far above the median.
  const double t_max = groups.back().t;
  const std::size_t P = static_cast<std::size_t>(W) * H;
  for (int c = 0; c < C; ++c) {
    std::vector<float> level(P);
    for (std::size_t p = 0; p < P; ++p) level[p] = d.level(p * C + c, t_max);
    std::vector<float> tmp = level;
    const double med = upper_median_inplace(tmp);
    const double sigma = std::max(kMadToSigma * upper_mad_inplace(tmp, med), 0.5);
    const double limit = med + std::max(options.hot_sigma * sigma, options.hot_min_dn);
    for (std::size_t p = 0; p < P; ++p)
      if (level[p] > limit) d.hot.data()[p] = 1;
    if (pooled_dof > 0) {
      std::vector<float> sd(P);
      for (std::size_t p = 0; p < P; ++p) sd[p] = std::sqrt(pooled_var[p * C + c]);
      std::vector<float> tmp2 = sd;
      const double med_sd = std::max(upper_median_inplace(tmp2), 0.5);
      for (std::size_t p = 0; p < P; ++p)
        if (sd[p] > options.noisy_factor * med_sd) d.hot.data()[p] = 1;
    }
  }
  double sum_b = 0.0, sum_r = 0.0;
  long long n = 0;
  for (std::size_t p = 0; p < P; ++p) {
    if (d.hot.data()[p]) {
      ++d.hot_count;
      continue;
    }
    for (int c = 0; c < C; ++c) {
      sum_b += d.bias_dn.data()[p * C + c];
      sum_r += d.rate_dn_per_s.data()[p * C + c];
      ++n;
    }
  }
  if (n == 0) throw CalibrationError("dark: every pixel is hot; these are not dark frames");
  d.mean_bias_dn = sum_b / static_cast<double>(n);
  d.mean_rate_dn_per_s = sum_r / static_cast<double>(n);
  return d;
}

Json DarkFrame::to_json(const std::string& map_file, const std::string& map_sha256) const {
  Json j = {{"provenance", provenance.to_json()},
            {"bit_depth", bit_depth},
            {"width", width()},
            {"height", height()},
            {"channels", channels()},
            {"frame_count", frame_count},
            {"exposures_s", exposures_s},
            {"mean_bias_dn", mean_bias_dn},
            {"mean_rate_dn_per_s", mean_rate_dn_per_s},
            {"hot_count", hot_count},
            {"hot_fraction", hot_fraction()},
            {"maps", {{"file", map_file}, {"sha256", map_sha256}}}};
  j["read_noise_dn"] = read_noise_measured ? Json(read_noise_dn) : Json(nullptr);
  return j;
}

void DarkFrame::save(const fs::path& json_path) const {
  ExrImage maps;
  add_map_planes(maps, "bias", bias_dn);
  add_map_planes(maps, "rate", rate_dn_per_s);
  ImageF h(width(), height(), 1);
  for (std::size_t p = 0; p < h.size(); ++p) h.data()[p] = hot.data()[p];
  maps.add("hot", std::move(h));
  save_map_record(json_path, std::move(maps), "dark", *this);
}

DarkFrame DarkFrame::load(const fs::path& json_path) {
  const MapRecord rec = read_map_record(json_path);
  DarkFrame d;
  rec.fill(d);
  d.bit_depth = rec.get<int>("bit_depth");
  d.mean_bias_dn = rec.get<double>("mean_bias_dn");
  d.mean_rate_dn_per_s = rec.get<double>("mean_rate_dn_per_s");
  if (rec.json.contains("read_noise_dn") && !rec.json.at("read_noise_dn").is_null()) {
    d.read_noise_dn = rec.get<double>("read_noise_dn");
    d.read_noise_measured = true;
  }
  d.bias_dn = rec.map("bias");
  d.rate_dn_per_s = rec.map("rate");
  d.hot = ImageU8(rec.width, rec.height, 1);
  const ImageF& h = rec.maps.plane("hot");
  for (std::size_t p = 0; p < h.size(); ++p) {
    d.hot.data()[p] = h.data()[p] > 0.5f ? 1 : 0;
    d.hot_count += d.hot.data()[p];
  }
  return d;
}

}  // namespace paintlab::calib
