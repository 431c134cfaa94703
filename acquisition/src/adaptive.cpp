#include "paintlab/acquisition/adaptive.h"

#include <algorithm>
#include <cmath>

#include "paintlab/core/error.h"

namespace paintlab::acq {

void AdaptiveOptions::check() const {
  if (!(linear_saturation > 0) || !std::isfinite(linear_saturation))
    throw UsageError("AdaptiveOptions::linear_saturation must be > 0");
  if (!(linear_floor >= 0) || !(linear_floor < linear_saturation))
    throw UsageError("AdaptiveOptions::linear_floor must be in [0, linear_saturation)");
  if (!(margin >= 1)) throw UsageError("AdaptiveOptions::margin must be >= 1");
}

AdaptiveBracketing::AdaptiveBracketing(AdaptiveOptions options, Image<std::uint8_t> mask)
    : options_(std::move(options)), mask_(std::move(mask)) {
  options_.check();
}

std::vector<double> AdaptiveBracketing::choose(const std::vector<double>& bracket_s, const ExrImage* previous) {
  if (!previous) return bracket_s;
  const ImageF* e = previous->find(options_.channel);
  if (!e) return bracket_s;
  const bool use_mask = !mask_.empty();
  if (use_mask && (mask_.width() != e->width() || mask_.height() != e->height())) return bracket_s;
  // Sorted radiances of the sphere pixels: an exposure t helps when some radiance E lies
  // in (floor / t, saturation / t).
  std::vector<float> values;
  values.reserve(e->size());
  const float* v = e->data();
  for (std::size_t i = 0; i < e->size(); ++i) {
    if (use_mask && !mask_.data()[i]) continue;
    if (v[i] > 0 && std::isfinite(v[i])) values.push_back(v[i]);
  }
  if (values.empty()) return bracket_s;
  std::sort(values.begin(), values.end());
  const double floor = options_.linear_floor / options_.margin;
  const double sat = options_.linear_saturation * options_.margin;
  std::vector<double> keep;
  for (double t : bracket_s) {
    auto first_above_floor = std::upper_bound(values.begin(), values.end(), static_cast<float>(floor / t));
    auto first_saturated = std::lower_bound(values.begin(), values.end(), static_cast<float>(sat / t));
    if (first_above_floor < first_saturated) keep.push_back(t);
  }
  if (keep.empty()) {
    // Everything saturates even at the shortest exposure or stays dark even at the longest:
    // the nearest end of the bracket is the only exposure that can help.
    keep.push_back(values.front() * bracket_s.front() >= sat ? bracket_s.front() : bracket_s.back());
  }
  return keep;
}

}  // namespace paintlab::acq
