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
