// The colour pipeline's accuracy on strongly coloured paints, the whole chain as a technician
// runs it on the quick simulated rig a colour demo calibrated (its DIR/rig.toml and calib/):
// measure and fit each paint, then compare with the paint the simulator showed. The tests
// are in demo_test.cpp (each colour camera's demo goes on to measure these paints).
#include "colour_accuracy.h"

#include <cmath>
#include <cstdio>

#include "paintlab/core/json.h"
#include "test_util.h"

namespace paintlab::colour_accuracy {

double relative_error(const Json& fit, const Json& truth) {
  return std::abs(fit.get<double>() - truth.get<double>()) / std::abs(truth.get<double>());
}

Fitted measure_and_fit(const fs::path& demo_dir, const std::string& paint_name) {
  const fs::path paint = test::source_dir() / "paints" / (paint_name + ".toml");
  const fs::path session = demo_dir / ("session-" + paint_name), fit = demo_dir / (paint_name + ".fit.json");
  auto r = test::run_paintlab("measure --rig " + (demo_dir / "rig.toml").string() + " --sample " + paint_name +
                                  " --out " + session.string() + " --sim-paint " + paint.string(),
                              240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  r = test::run_paintlab("fit " + session.string() + " --model cook-torrance --lobes 2 --out " + fit.string(), 240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  std::printf("%s:\n%s", paint_name.c_str(), r.out.c_str());
  if (!fs::exists(fit)) return {};
  return {read_json_file(session / "session.json")["options"]["sim_paint"], read_json_file(fit)};
}

}  // namespace paintlab::colour_accuracy
