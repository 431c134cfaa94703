#pragma once
// Adaptive bracketing (`paintlab measure --adaptive`): at each light position, capture only
// the exposures that can add a pixel on the sphere that is unsaturated and above the
// noise floor. The prediction uses the merged radiance of the previous position (the light
// moves by a small step, so radiance changes little) with a safety margin; the first
// position, and any position after a large change, uses the full bracket.
#include <cstdint>
#include <vector>

#include "paintlab/acquisition/runner.h"
#include "paintlab/core/image.h"

namespace paintlab::acq {

struct AdaptiveOptions {
  // Usable range of one exposure in linearised DN (the HDR merge's units x seconds): a
  // pixel of radiance E adds information at exposure t when floor < E t < saturation.
  double linear_floor = 0.0;
  double linear_saturation = 0.0;
  // The predicted range is widened by this factor on both sides (radiance may change
  // between positions): keep t when floor / margin < E t < saturation * margin.
  double margin = 2.0;
  // Radiance channel of the merged image ("Y", or "G" for RGB cameras).
  std::string channel = "Y";

  void check() const;  // UsageError naming the first violated rule
};

class AdaptiveBracketing final : public ExposurePlanner {
 public:
  // mask: 1 = sphere pixel (same size as the merged images); empty = every pixel counts.
  AdaptiveBracketing(AdaptiveOptions options, Image<std::uint8_t> mask);
  std::vector<double> choose(const std::vector<double>& bracket_s, const ExrImage* previous) override;

 private:
  AdaptiveOptions options_;
  Image<std::uint8_t> mask_;
};

}  // namespace paintlab::acq
