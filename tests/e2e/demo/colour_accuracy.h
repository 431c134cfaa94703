#pragma once
// Measuring and fitting a paint on the rig a demo calibrated (colour_accuracy_test.cpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/core/json.h"

namespace paintlab::colour_accuracy {

namespace fs = std::filesystem;

// |fit - truth| / |truth| of two JSON numbers.
double relative_error(const Json& fit, const Json& truth);

// The paint the simulator showed (session.json's sim_paint) and the 2-lobe fit.
struct Fitted {
  Json truth, fit;
};
// `paintlab measure` of paints/NAME.toml on DIR/rig.toml (calibrated by the demo in DIR) into
// DIR/session-NAME and `paintlab fit --lobes N` into DIR/NAME.fit.json; EXPECT failures when
// either fails (empty JSON then).
Fitted measure_and_fit(const fs::path& demo_dir, const std::string& paint_name, int lobes = 2);

// `paintlab fit --lobes N FLAGS` of DIR/session-NAME (measure_and_fit measured it) into
// DIR/NAME.LABEL.fit.json; an EXPECT failure and empty JSON when it fails.
Json fit_again(const fs::path& demo_dir, const std::string& paint_name, int lobes, const std::string& flags,
               const std::string& label);

// The paint file's, the measurement's and the fit's CIELAB at each five-angle geometry
// (`paintlab colour`), for paints judged as a paint lab judges them: dE00 of the measured
// values and of the fit against the paint's own.
struct FiveAngle {
  std::vector<std::string> names;
  std::vector<double> measured_de00, fit_de00;
};
FiveAngle five_angle_against_truth(const fs::path& demo_dir, const std::string& paint_name);

}  // namespace paintlab::colour_accuracy
