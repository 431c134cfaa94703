#include "paintlab/acquisition/adaptive.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "paintlab/core/error.h"

namespace paintlab::acq {

void AdaptiveOptions::check() const {
  auto fail = [](const char* field, double value, const char* rule) {
    throw OptionError(std::string("AdaptiveOptions::") + field, fmt::format("{}", value), rule);
  };
  if (!(linear_saturation > 0) || !std::isfinite(linear_saturation)) fail("linear_saturation", linear_saturation, "> 0");
  if (!(linear_floor >= 0) || !(linear_floor < linear_saturation))
    fail("linear_floor", linear_floor, "[0, linear_saturation)");
  if (!(margin >= 1)) fail("margin", margin, ">= 1");
  if (!(read_noise_dn >= 0)) fail("read_noise_dn", read_noise_dn, ">= 0");
  if (!(gain_dn_per_e >= 0)) fail("gain_dn_per_e", gain_dn_per_e, ">= 0");
  if (!(max_information_loss >= 0) || !(max_information_loss < 1))
    fail("max_information_loss", max_information_loss, "[0, 1)");
}

AdaptiveBracketing::AdaptiveBracketing(AdaptiveOptions options, Image<std::uint8_t> mask)
    : options_(std::move(options)), mask_(std::move(mask)) {
  options_.check();
}

std::vector<double> AdaptiveBracketing::choose_for_filter(int filter, const std::vector<double>& bracket_s,
                                                         const ExrImage* previous) {
  if (!filter_source_) return choose(bracket_s, previous);
  last_worst_loss_ = 0.0;
  if (!previous) return bracket_s;  // the first position: the full bracket through every filter
  const std::shared_ptr<const ExrImage> merged = filter_source_(filter);
  if (!merged) return bracket_s;
  return choose(bracket_s, merged.get());  // that filter's merge, planned as a monochrome image
}

std::vector<double> AdaptiveBracketing::choose(const std::vector<double>& bracket_s, const ExrImage* previous) {
  last_worst_loss_ = 0.0;
  if (!previous || bracket_s.empty()) return bracket_s;
  std::shared_ptr<const ExrImage> mosaic;
  if (source_) {
    mosaic = source_();
    if (!mosaic) return bracket_s;
    previous = mosaic.get();
  }
  const ImageF* e = previous->find(options_.channel);
  if (!e) return bracket_s;
  const bool use_mask = !mask_.empty();
  if (use_mask && (mask_.width() != e->width() || mask_.height() != e->height())) return bracket_s;

  // The radiances of the valid sphere pixels, as a set of log2 bins (32 per octave: pixels
  // of one bin get the same plan within 2 %). Invalid pixels hold bounds: one saturated even
  // in the shortest exposure asks for that exposure; one dark in every exposure cannot be
  // helped by any of them and is left out.
  constexpr double kBinsPerOctave = 32.0;
  const ImageF* valid = previous->find("valid");
  const double t_min = *std::min_element(bracket_s.begin(), bracket_s.end());
  bool saturated = false;
  std::set<long> bins;
  const float* v = e->data();
  for (std::size_t i = 0; i < e->size(); ++i) {
    if (use_mask && !mask_.data()[i]) continue;
    if (!(v[i] > 0) || !std::isfinite(v[i])) continue;
    if (valid && valid->data()[i] < 0.5f) {
      if (v[i] * t_min >= 0.5 * options_.linear_saturation) saturated = true;
      continue;
    }
    // Planned for E / margin, E and E x margin: the radiance at the next position is not
    // known exactly.
    for (double s : {1.0 / options_.margin, 1.0, options_.margin})
      bins.insert(std::lround(std::floor(std::log2(v[i] * s) * kBinsPerOctave)));
  }
  if (bins.empty()) return saturated ? std::vector<double>{t_min} : bracket_s;

  // share[r][j]: exposure j's share of the information of representative radiance r.
  const std::size_t n = bracket_s.size();
  std::vector<std::vector<double>> share;
  share.reserve(bins.size());
  for (long b : bins) {
    const double radiance = std::exp2((static_cast<double>(b) + 0.5) / kBinsPerOctave);
    std::vector<double> info(n, 0.0);
    double total = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const double u = radiance * bracket_s[j];
      if (!(u > options_.linear_floor) || !(u < options_.linear_saturation)) continue;
      const double var = std::max(options_.read_noise_dn * options_.read_noise_dn, 1.0 / 12.0) +
                         options_.gain_dn_per_e * u;
      info[j] = bracket_s[j] * bracket_s[j] / var;
      total += info[j];
    }
    if (total <= 0) continue;  // no exposure of the bracket sees it
    for (double& x : info) x /= total;
    share.push_back(std::move(info));
  }
  if (share.empty()) {
    // Every pixel saturates even at the shortest exposure or stays dark even at the longest:
    // the nearest end of the bracket is the only exposure that can help.
    const double t_max = *std::max_element(bracket_s.begin(), bracket_s.end());
    return {saturated ? t_min : t_max};
  }

  // Drop exposures, smallest largest-share first, while no radiance loses more than the
  // budget. Exposures no pixel uses (share 0 everywhere) always go.
  std::vector<double> worst(n, 0.0);
  for (const auto& row : share)
    for (std::size_t j = 0; j < n; ++j) worst[j] = std::max(worst[j], row[j]);
  std::vector<std::size_t> order(n);
  for (std::size_t j = 0; j < n; ++j) order[j] = j;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return worst[a] < worst[b]; });
  std::vector<double> lost(share.size(), 0.0);
  std::vector<bool> dropped(n, false);
  for (std::size_t j : order) {
    double peak = 0;
    for (std::size_t r = 0; r < share.size(); ++r) peak = std::max(peak, lost[r] + share[r][j]);
    if (worst[j] > 0 && peak > options_.max_information_loss) continue;
    dropped[j] = true;
    for (std::size_t r = 0; r < share.size(); ++r) lost[r] += share[r][j];
  }
  std::vector<double> keep;
  for (std::size_t j = 0; j < n; ++j)
    if (!dropped[j] || (saturated && bracket_s[j] == t_min)) keep.push_back(bracket_s[j]);
  last_worst_loss_ = lost.empty() ? 0.0 : *std::max_element(lost.begin(), lost.end());
  return keep;
}

}  // namespace paintlab::acq
