#pragma once
// Measuring and fitting a paint on the rig a demo calibrated (colour_accuracy_test.cpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "paintlab/core/json.h"

namespace paintlab::colour_accuracy {

namespace fs = std::filesystem;

// |fit - truth| / |truth| of two JSON numbers.
double relative_error(const Json& fit, const Json& truth);

// The paint the simulator showed (session.json's sim_paint) and the 2-lobe fit.
struct Fitted {
  Json truth, fit;
};
// `paintlab measure` of paints/NAME.toml on DIR/rig.toml (calibrated by the demo in DIR) and
// `paintlab fit --lobes 2`; EXPECT failures when either fails (empty JSON then).
Fitted measure_and_fit(const fs::path& demo_dir, const std::string& paint_name);

}  // namespace paintlab::colour_accuracy
