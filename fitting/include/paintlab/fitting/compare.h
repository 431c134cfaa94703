#pragma once
// A fitted paint against a known one (the simulator's truth, a reference paint): the table
// `paintlab demo` prints, per parameter and per channel, with the relative error of each.
#include <string>

#include "paintlab/core/json.h"

namespace paintlab::fit {

// Both are Cook-Torrance paint JSON (brdf::to_json, fit.json: "kd" [3], "lobes" [{"ks" [3],
// "m", "r"}]); `stddev` is fit.json's "stddev" (or an empty object). One line per parameter:
// truth, fit, standard deviation and the relative error (fit / truth - 1) in percent per
// channel; "-" where a side lacks the value (a lobe the other has not).
std::string compare_table(const Json& truth, const Json& fit, const Json& stddev);

}  // namespace paintlab::fit

#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/merl.h"

namespace paintlab::fit {

// A measured table against a known paint by how grazing its bins are: for every measured
// bin, log(measured / paint) per channel with the paint evaluated at the bin's mean
// coordinates, grouped by the band of max(theta_i, theta_o) the bin's mean direction pair
// falls in. The bands near 90 deg are where the terminator and the silhouette are (docs/
// fitting.md "Lens blur").
struct GrazingBand {
  double lo_deg = 0.0, hi_deg = 0.0;
  std::size_t bins = 0;          // measured bins with both values > 0 in every channel
  std::size_t non_positive = 0;  // measured bins left out: a value <= 0 (no logarithm)
  double rms = 0.0;              // of the log ratios, channels pooled
  double median = 0.0, p05 = 0.0, p95 = 0.0;
};
// `edges_deg`: increasing band edges in [0, 90] (at least two).
std::vector<GrazingBand> compare_by_grazing_band(const brdf::MerlTable& measured, const brdf::Brdf& paint,
                                                 std::vector<double> edges_deg = {0, 60, 75, 80, 85, 90});
// One line per band: "max(theta_i, theta_o) 85-90 deg: 30739 bins, log ratio RMS 1.07, ...".
std::string grazing_band_table(const std::vector<GrazingBand>& bands);
Json grazing_band_json(const std::vector<GrazingBand>& bands);

}  // namespace paintlab::fit
