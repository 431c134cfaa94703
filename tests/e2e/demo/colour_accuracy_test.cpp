// The colour pipeline's accuracy on strongly coloured paints, the whole chain as a technician
// runs it on the quick simulated rig a colour demo calibrated (its DIR/rig.toml and calib/):
// measure and fit each paint, then compare with the paint the simulator showed. The tests
// are in demo_test.cpp (each colour camera's demo goes on to measure these paints).
#include "colour_accuracy.h"

#include <cmath>
#include <cstdio>

#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "test_util.h"

namespace paintlab::colour_accuracy {

double relative_error(const Json& fit, const Json& truth) {
  return std::abs(fit.get<double>() - truth.get<double>()) / std::abs(truth.get<double>());
}

Fitted measure_and_fit(const fs::path& demo_dir, const std::string& paint_name, int lobes) {
  const fs::path paint = test::source_dir() / "paints" / (paint_name + ".toml");
  const fs::path session = demo_dir / ("session-" + paint_name), fit = demo_dir / (paint_name + ".fit.json");
  auto r = test::run_paintlab("measure --rig " + (demo_dir / "rig.toml").string() + " --sample " + paint_name +
                                  " --out " + session.string() + " --sim-paint " + paint.string(),
                              240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  r = test::run_paintlab(
      "fit " + session.string() + " --model cook-torrance --lobes " + std::to_string(lobes) + " --out " + fit.string(),
      240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  std::printf("%s:\n%s", paint_name.c_str(), r.out.c_str());
  if (!fs::exists(fit)) return {};
  return {read_json_file(session / "session.json")["options"]["sim_paint"], read_json_file(fit)};
}

Json fit_again(const fs::path& demo_dir, const std::string& paint_name, int lobes, const std::string& flags,
               const std::string& label) {
  const fs::path session = demo_dir / ("session-" + paint_name), fit = demo_dir / (paint_name + "." + label + ".fit.json");
  const auto r = test::run_paintlab("fit " + session.string() + " --model cook-torrance --lobes " +
                                        std::to_string(lobes) + " " + flags + " --out " + fit.string(),
                                    240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  std::printf("%s, fit %s:\n%s", paint_name.c_str(), flags.c_str(), r.out.c_str());
  return fs::exists(fit) ? read_json_file(fit) : Json();
}

namespace {
colour::Lab lab_of(const Json& j) { return {j["L"].get<double>(), j["a"].get<double>(), j["b"].get<double>()}; }
}  // namespace

FiveAngle five_angle_against_truth(const fs::path& demo_dir, const std::string& paint_name) {
  FiveAngle out;
  const fs::path paint = test::source_dir() / "paints" / (paint_name + ".toml");
  const auto t = test::run_paintlab("colour " + paint.string() + " --json");
  const auto m = test::run_paintlab("colour " + (demo_dir / ("session-" + paint_name)).string() + " --fit " +
                                    (demo_dir / (paint_name + ".fit.json")).string() + " --json");
  EXPECT_EQ(t.exit_code, 0) << t.err;
  EXPECT_EQ(m.exit_code, 0) << m.err;
  if (t.exit_code != 0 || m.exit_code != 0) return out;
  const Json truth = Json::parse(t.out), measured = Json::parse(m.out);
  std::printf("%s, five-angle CIELAB: the measurement's and the fit's dE00 against the paint's\n", paint_name.c_str());
  for (std::size_t i = 0; i < truth["geometries"].size(); ++i) {
    const Json& g = measured["geometries"][i];
    const colour::Lab paint_lab = lab_of(truth["geometries"][i]["model"]);
    out.names.push_back(g["name"].get<std::string>());
    out.measured_de00.push_back(colour::delta_e_2000(lab_of(g["measured"]), paint_lab));
    out.fit_de00.push_back(colour::delta_e_2000(lab_of(g["model"]), paint_lab));
    std::printf("  %-8s L* %6.2f: measured dE00 %.2f (n %d), fit dE00 %.2f\n", out.names.back().c_str(), paint_lab.L,
                out.measured_de00.back(), g["measured"]["n"].get<int>(), out.fit_de00.back());
  }
  return out;
}

}  // namespace paintlab::colour_accuracy
