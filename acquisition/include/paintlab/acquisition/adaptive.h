#pragma once
// Adaptive bracketing (`paintlab measure --adaptive`): at each light position, capture only
// the exposures that add something to a pixel on the sphere. An exposure t adds to a pixel
// of radiance E when E t lies between the noise floor and saturation; what it adds is its
// share of the pixel's Fisher information, t^2 / var(E t) over the sum of that over the
// bracket (the HDR merge weights by inverse variance, so the merged variance is 1 / the
// sum). An exposure is dropped when it adds nothing to any pixel (the literal rule), and
// further exposures are dropped, smallest contribution first, while no pixel loses more
// than `max_information_loss` of its information: the merged SNR of every pixel then stays
// within sqrt(1 - max_information_loss) of the full bracket's (0.954 at the default 0.09).
// Why not only the literal rule: a sphere's radiance is a continuum (down to the shadow
// line, up to the highlight) that every exposure of a dense bracket sees a few pixels of,
// so the literal rule alone drops nothing; but those pixels get almost all of their
// information from neighbouring exposures.
// The radiance is predicted from the merged image of the previous position (the light
// moves by a small step) and each pixel is planned for E / margin, E and E x margin; the
// first position, and any after a foreign image, uses the full bracket.
#include <cstdint>
#include <functional>
#include <memory>
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
  // Noise of one linearised value u (DN): var = max(read_noise_dn^2, 1/12) + gain_dn_per_e u.
  // Unknown (0, 0): quantisation only, which makes the plan favour long exposures.
  double read_noise_dn = 0.0;
  double gain_dn_per_e = 0.0;
  // Largest share of any pixel's information the dropped exposures may carry, in [0, 1).
  double max_information_loss = 0.09;
  // Radiance channel of the merged image ("Y", or "G" for RGB cameras).
  std::string channel = "Y";

  void check() const;  // UsageError naming the first violated rule
};

class AdaptiveBracketing final : public ExposurePlanner {
 public:
  // mask: 1 = sphere pixel (same size as the merged images); empty = every pixel counts.
  AdaptiveBracketing(AdaptiveOptions options, Image<std::uint8_t> mask);
  std::vector<double> choose(const std::vector<double>& bracket_s, const ExrImage* previous) override;
  // Where the radiance comes from instead of `previous` (when there is one): a colour camera's
  // merged mosaic, whose every site is planned as the pixel it is (BracketMerger::last_mosaic).
  void predict_from(std::function<std::shared_ptr<const ExrImage>()> source) { source_ = std::move(source); }
  // A filter-wheel camera: each filter's bracket is planned from that filter's last merged
  // image (BracketMerger::last_filter_merge), so each channel keeps the exposures it needs.
  void predict_per_filter(std::function<std::shared_ptr<const ExrImage>(int)> source) {
    filter_source_ = std::move(source);
  }
  std::vector<double> choose_for_filter(int filter, const std::vector<double>& bracket_s,
                                        const ExrImage* previous) override;
  // Largest information share a pixel lost in the last choose() (0 when nothing was dropped).
  double last_worst_loss() const { return last_worst_loss_; }

 private:
  AdaptiveOptions options_;
  Image<std::uint8_t> mask_;
  double last_worst_loss_ = 0.0;
  std::function<std::shared_ptr<const ExrImage>()> source_;
  std::function<std::shared_ptr<const ExrImage>(int)> filter_source_;
};

}  // namespace paintlab::acq
