#include "paintlab/calibration/flat.h"

#include "map_file.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "paintlab/calibration/dark.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/robust.h"

namespace fs = std::filesystem;

namespace paintlab::calib {

void FlatOptions::check() const {
  if (!(max_saturated_fraction >= 0.0 && max_saturated_fraction < 1.0))
    throw UsageError(fmt::format("flat: max_saturated_fraction = {}; must be in [0, 1)", max_saturated_fraction));
  if (!(min_signal_frac > 0.0 && min_signal_frac < 1.0))
    throw UsageError(fmt::format("flat: min_signal_frac = {}; must be in (0, 1)", min_signal_frac));
}

FlatField calibrate_flat(std::span<const StackFrame> frames, int bit_depth, const FlatOptions& options,
                         const ResponseCurve* response, const DarkFrame* dark) {
  options.check();
  check_stack(frames, bit_depth, 1);
  const auto& first = *frames[0].pixels;
  const int W = first.width();
  const int H = first.height();
  const int C = first.channels();
  const std::size_t S = first.size();
  const std::size_t P = first.pixel_count();
  if (dark && (dark->width() != W || dark->height() != H || dark->channels() != C))
    throw DataError(fmt::format("flat: the dark frame is {}x{}x{}, the images {}x{}x{}", dark->width(), dark->height(),
                                dark->channels(), W, H, C));
  if (response && response->channels != C)
    throw DataError(fmt::format("flat: the response has {} channel(s), the images {}", response->channels, C));

  const double full_scale = std::ldexp(1.0, bit_depth) - 1.0;
  const double saturation = response ? response->window.saturation_dn : full_scale;
  const double black = response ? response->window.black_dn : 0.0;

  // Linearised value per second, averaged over the frames.
  std::vector<double> sum(S, 0.0);
  std::vector<int> count(S, 0);
  long long saturated = 0;
  double signal_sum = 0.0;
  for (const auto& f : frames) {
    const std::uint16_t* z = f.pixels->data();
    for (std::size_t s = 0; s < S; ++s) {
      const double d = dark ? dark->level(s, f.exposure_s) : black;
      const double u = z[s] - d;
      signal_sum += u;
      if (z[s] >= saturation) {
        ++saturated;
        continue;
      }
      const double y = response ? response->to_linear(static_cast<int>(s % C), u) : u;
      sum[s] += y / f.exposure_s;
      ++count[s];
    }
  }
  FlatField out;
  out.frame_count = static_cast<int>(frames.size());
  for (const auto& f : frames) {
    if (std::none_of(out.exposures_s.begin(), out.exposures_s.end(),
                     [&](double t) { return std::abs(t - f.exposure_s) <= 1e-6 * t; }))
      out.exposures_s.push_back(f.exposure_s);
  }
  const double total = static_cast<double>(S) * static_cast<double>(frames.size());
  out.saturated_fraction = static_cast<double>(saturated) / total;
  out.mean_signal_dn = signal_sum / total;
  if (out.saturated_fraction > options.max_saturated_fraction)
    throw CalibrationError(fmt::format(
        "flat: {:.3g} % of the values are at or above saturation ({} DN), {:.3g} % allowed; lower the exposure or "
        "the light",
        100.0 * out.saturated_fraction, saturation, 100.0 * options.max_saturated_fraction));
  if (out.mean_signal_dn < options.min_signal_frac * full_scale)
    throw CalibrationError(fmt::format(
        "flat: mean signal {:.1f} DN is below {:.0f} % of full scale ({} DN); raise the exposure or the light",
        out.mean_signal_dn, 100.0 * options.min_signal_frac, full_scale));

  auto trusted = [&](std::size_t p) { return !(dark && dark->hot.data()[p]); };
  if (options.cfa && C != 1)
    throw DataError(fmt::format("flat: colour-filter-array frames have one plane, these have {}", C));
  out.cfa = options.cfa;
  // The classes normalised on their own: the channels, or a mosaic's filter colours.
  const int classes = options.cfa ? 3 : C;
  auto class_of = [&](std::size_t s) {
    if (!options.cfa) return static_cast<int>(s % static_cast<std::size_t>(C));
    const std::size_t x = s % static_cast<std::size_t>(W), y = s / static_cast<std::size_t>(W);
    return (*options.cfa)[2 * (y & 1) + (x & 1)];
  };
  std::vector<double> acc(static_cast<std::size_t>(classes), 0.0);
  std::vector<long long> n(static_cast<std::size_t>(classes), 0);
  for (std::size_t s = 0; s < S; ++s) {
    if (!trusted(s / static_cast<std::size_t>(C)) || count[s] == 0) continue;
    acc[static_cast<std::size_t>(class_of(s))] += sum[s] / count[s];
    ++n[static_cast<std::size_t>(class_of(s))];
  }
  for (int k = 0; k < classes; ++k)
    if (n[static_cast<std::size_t>(k)] == 0 || !(acc[static_cast<std::size_t>(k)] > 0.0))
      throw CalibrationError(fmt::format("flat: no usable pixel in {} {}", options.cfa ? "filter colour" : "channel", k));
  out.gain = ImageF(W, H, C);
  for (std::size_t s = 0; s < S; ++s) {
    const auto k = static_cast<std::size_t>(class_of(s));
    const double mean = acc[k] / static_cast<double>(n[k]);
    out.gain.data()[s] = (!trusted(s / static_cast<std::size_t>(C)) || count[s] == 0)
                             ? 1.0f
                             : static_cast<float>(sum[s] / count[s] / mean);
  }

  // Corner and centre blocks (1/8 of each side), averaged over the channels.
  const int bw = std::max(1, W / 8);
  const int bh = std::max(1, H / 8);
  auto block_mean = [&](int x0, int y0) {
    double acc = 0.0;
    long long n = 0;
    for (int y = y0; y < y0 + bh; ++y)
      for (int x = x0; x < x0 + bw; ++x) {
        if (!trusted(static_cast<std::size_t>(y) * W + x)) continue;
        for (int c = 0; c < C; ++c) acc += out.gain.at(x, y, c);
        n += C;
      }
    return n > 0 ? acc / static_cast<double>(n) : 1.0;
  };
  const double corners[4] = {block_mean(0, 0), block_mean(W - bw, 0), block_mean(0, H - bh),
                             block_mean(W - bw, H - bh)};
  const double lo = *std::min_element(corners, corners + 4);
  const double hi = *std::max_element(corners, corners + 4);
  out.corner_ratio = hi > 0.0 ? lo / hi : 0.0;
  const double centre = block_mean((W - bw) / 2, (H - bh) / 2);
  out.centre_to_corner = centre > 0.0 ? lo / centre : 0.0;

  // Pixel non-uniformity: gain relative to its 7x7 local mean (of a mosaic: among the sites of
  // one 2x2 phase, 7x7 of them, so that one colour is never compared with another).
  if (options.cfa) {
    std::vector<float> rel;
    rel.reserve(S);
    for (int phase = 0; phase < 4; ++phase) {
      const int x0 = phase & 1, y0 = phase >> 1;
      const int w = (W - x0 + 1) / 2, h = (H - y0 + 1) / 2;
      cv::Mat g(h, w, CV_32F), ok(h, w, CV_8U);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          g.at<float>(y, x) = out.gain.at(x0 + 2 * x, y0 + 2 * y);
          ok.at<std::uint8_t>(y, x) = trusted(static_cast<std::size_t>(y0 + 2 * y) * W + x0 + 2 * x) ? 1 : 0;
        }
      cv::Mat local;
      cv::blur(g, local, cv::Size(7, 7), cv::Point(-1, -1), cv::BORDER_REFLECT);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (ok.at<std::uint8_t>(y, x) && local.at<float>(y, x) > 0.0f)
            rel.push_back(g.at<float>(y, x) / local.at<float>(y, x) - 1.0f);
    }
    out.prnu_rel = rel.empty() ? 0.0 : kMadToSigma * upper_mad_inplace(rel, 0.0);
  } else {
    std::vector<float> rel;
    rel.reserve(S);
    for (int c = 0; c < C; ++c) {
      cv::Mat g(H, W, CV_32F);
      for (std::size_t p = 0; p < P; ++p) g.ptr<float>()[p] = out.gain.data()[p * C + c];
      cv::Mat local;
      cv::blur(g, local, cv::Size(7, 7), cv::Point(-1, -1), cv::BORDER_REFLECT);
      for (std::size_t p = 0; p < P; ++p)
        if (trusted(p) && local.ptr<float>()[p] > 0.0f) rel.push_back(g.ptr<float>()[p] / local.ptr<float>()[p] - 1.0f);
    }
    // 0, not NaN, when no pixel is trusted.
    out.prnu_rel = rel.empty() ? 0.0 : kMadToSigma * upper_mad_inplace(rel, 0.0);
  }

  // Photon transfer: var(z1 - z2) / 2 = read^2 + gain * u over pairs of frames of one exposure.
  {
    double read_var = dark && dark->read_noise_measured ? dark->read_noise_dn * dark->read_noise_dn : 0.0;
    double gain_sum = 0.0;
    int pairs = 0;
    for (std::size_t a = 0; a + 1 < frames.size(); ++a) {
      const auto& fa = frames[a];
      const auto& fb = frames[a + 1];
      if (std::abs(fa.exposure_s - fb.exposure_s) > 1e-6 * fa.exposure_s) continue;
      double sd = 0.0, sd2 = 0.0, su = 0.0;
      long long n = 0;
      for (std::size_t s = 0; s < S; ++s) {
        const std::uint16_t za = fa.pixels->data()[s];
        const std::uint16_t zb = fb.pixels->data()[s];
        if (za >= saturation || zb >= saturation || !trusted(s / C)) continue;
        const double d = static_cast<double>(za) - zb;
        sd += d;
        sd2 += d * d;
        su += 0.5 * (za + zb) - (dark ? dark->level(s, fa.exposure_s) : black);
        ++n;
      }
      if (n < 100) continue;
      const double var = (sd2 - sd * sd / n) / (n - 1) / 2.0;
      const double u = su / n;
      if (u > 0.0) {
        gain_sum += std::max(0.0, var - read_var) / u;
        ++pairs;
      }
    }
    if (pairs > 0) {
      out.noise.gain_dn_per_e = gain_sum / pairs;
      out.noise.read_noise_dn = std::sqrt(read_var);
      out.noise.source = dark && dark->read_noise_measured ? "flat (photon transfer) + dark" : "flat (photon transfer)";
    }
  }
  return out;
}

Json FlatField::to_json(const std::string& map_file, const std::string& map_sha256) const {
  return {{"provenance", provenance.to_json()},
          {"width", width()},
          {"height", height()},
          {"channels", channels()},
          {"frame_count", frame_count},
          {"exposures_s", exposures_s},
          {"corner_ratio", corner_ratio},
          {"centre_to_corner", centre_to_corner},
          {"prnu_rel", prnu_rel},
          {"mean_signal_dn", mean_signal_dn},
          {"saturated_fraction", saturated_fraction},
          {"noise", noise.to_json()},
          {"cfa", cfa ? Json(*cfa) : Json()},
          {"maps", {{"file", map_file}, {"sha256", map_sha256}}}};
}

void FlatField::save(const fs::path& json_path) const {
  ExrImage maps;
  add_map_planes(maps, "flat", gain);
  save_map_record(json_path, std::move(maps), "flat", *this);
}

FlatField FlatField::load(const fs::path& json_path) {
  const MapRecord rec = read_map_record(json_path);
  FlatField f;
  rec.fill(f);
  f.corner_ratio = rec.get<double>("corner_ratio");
  f.centre_to_corner = rec.get<double>("centre_to_corner");
  f.prnu_rel = rec.get<double>("prnu_rel");
  f.mean_signal_dn = rec.get<double>("mean_signal_dn");
  f.saturated_fraction = rec.get<double>("saturated_fraction");
  if (rec.json.contains("noise")) f.noise = NoiseModel::from_json(rec.json.at("noise"), rec.where);
  if (rec.json.contains("cfa") && !rec.json.at("cfa").is_null()) {
    const std::vector<int> cfa = json_get<std::vector<int>>(rec.json, "cfa", rec.where);
    if (cfa.size() != 4 || std::any_of(cfa.begin(), cfa.end(), [](int c) { return c < 0 || c > 2; }))
      throw DataError(rec.where + ": key 'cfa' must hold the colours (0 R, 1 G, 2 B) of the 2x2 filter block");
    f.cfa = std::array<int, 4>{cfa[0], cfa[1], cfa[2], cfa[3]};
  }
  f.gain = rec.map("flat");
  for (std::size_t p = 0; p < f.gain.size(); ++p) {
    const float v = f.gain.data()[p];
    if (!(v > 0.0f) || !std::isfinite(v))
      throw DataError(fmt::format("{}: its map's gain {} at value {} is not finite and > 0", rec.where, v, p));
  }
  return f;
}

}  // namespace paintlab::calib
