// The colour pipeline's accuracy on strongly coloured paints, the whole chain as a technician
// runs it (calibrate all, measure, fit) on the quick simulated rig with each colour camera:
// the monochrome camera behind the filter wheel meets the colour issue's targets on a deep
// blue solid and a red metallic (kd and every lobe's ks per channel, m, r); the Bayer camera
// meets them on kd and the broad lobe, while bilinear demosaicing widens the clear coat's
// few-pixel highlight (docs/colour.md, "what demosaicing costs").
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/json.h"
#include "paintlab/sim/builtin.h"
#include "test_util.h"

using namespace paintlab;
namespace fs = std::filesystem;

namespace {

double relative_error(const Json& fit, const Json& truth) {
  return std::abs(fit.get<double>() - truth.get<double>()) / std::abs(truth.get<double>());
}

struct Fitted {
  Json truth, fit;
};

// calibrate all + check on a fresh quick rig with `camera`, then measure and fit each paint.
std::vector<Fitted> measure_paints(const fs::path& dir, sim::DemoCamera camera, const std::vector<std::string>& paints) {
  const fs::path rig = dir / "rig.toml";
  write_file_atomic(rig, sim::demo_rig_toml(true, camera));
  const std::string R = rig.string();
  auto r = test::run_paintlab("calibrate all --rig " + R + " --capture", 240);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  std::vector<Fitted> out;
  for (const std::string& name : paints) {
    const fs::path paint = test::source_dir() / "paints" / (name + ".toml");
    const fs::path session = dir / ("session-" + name), fit = dir / (name + ".fit.json");
    r = test::run_paintlab("measure --rig " + R + " --sample " + name + " --out " + session.string() +
                               " --sim-paint " + paint.string(),
                           240);
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    r = test::run_paintlab("fit " + session.string() + " --model cook-torrance --lobes 2 --out " + fit.string(), 240);
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    std::printf("%s, %s camera:\n%s", name.c_str(), sim::to_string(camera), r.out.c_str());
    Json truth = read_json_file(session / "session.json")["options"]["sim_paint"];
    out.push_back({truth, read_json_file(fit)});
  }
  return out;
}

}  // namespace

TEST(ColourAccuracy, TheFilterWheelCameraMeetsTheTargetsOnABlueSolidAndARedMetallic) {
  test::TempDir dir;
  const auto fitted = measure_paints(dir.path(), sim::DemoCamera::Wheel, {"solid-blue", "red-metallic"});
  ASSERT_EQ(fitted.size(), 2u);
  for (const auto& [truth, fit] : fitted) {
    SCOPED_TRACE(truth["name"].get<std::string>());
    ASSERT_EQ(fit["lobes"].size(), 2u);
    EXPECT_EQ(fit["input"]["colour_space"], "linear sRGB (D65)");
    for (int c = 0; c < 3; ++c) {
      // The red metallic's blue kd is 0.010 next to a red of 0.180: what the colour matrix
      // leaves of the red in blue (0.0003 here, 0.2 % of the red) is 3.3 % of it.
      const double kd_tolerance = truth["kd"][c].get<double>() < 0.2 * truth["kd"][0].get<double>() &&
                                          truth["kd"][0].get<double>() > truth["kd"][2].get<double>()
                                      ? 0.04
                                      : 0.03;
      EXPECT_LT(relative_error(fit["kd"][c], truth["kd"][c]), kd_tolerance) << "kd " << c;
      EXPECT_LT(relative_error(fit["lobes"][0]["ks"][c], truth["lobes"][0]["ks"][c]), 0.03) << "lobe 1 ks " << c;
      EXPECT_LT(relative_error(fit["lobes"][1]["ks"][c], truth["lobes"][1]["ks"][c]), 0.08) << "clear coat ks " << c;
    }
    for (int l = 0; l < 2; ++l) {
      EXPECT_LT(relative_error(fit["lobes"][l]["m"], truth["lobes"][l]["m"]), 0.02) << "lobe " << l + 1 << " m";
      EXPECT_LT(relative_error(fit["lobes"][l]["r"], truth["lobes"][l]["r"]), 0.05) << "lobe " << l + 1 << " r";
    }
  }
}

TEST(ColourAccuracy, TheBayerCameraMeetsThemOnTheDiffuseAndBroadLobesAndWidensTheClearCoat) {
  test::TempDir dir;
  const auto fitted = measure_paints(dir.path(), sim::DemoCamera::Bayer, {"red-metallic"});
  ASSERT_EQ(fitted.size(), 1u);
  const Json& truth = fitted[0].truth;
  const Json& fit = fitted[0].fit;
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(relative_error(fit["kd"][c], truth["kd"][c]), 0.03) << "kd " << c;
    EXPECT_LT(relative_error(fit["lobes"][0]["ks"][c], truth["lobes"][0]["ks"][c]), 0.05) << "lobe 1 ks " << c;
  }
  EXPECT_LT(relative_error(fit["lobes"][0]["m"], truth["lobes"][0]["m"]), 0.02);
  EXPECT_LT(relative_error(fit["lobes"][0]["r"], truth["lobes"][0]["r"]), 0.05);
  // The clear coat (m 0.02, a highlight 2-3 px across at this resolution) comes out wider
  // (m +11 % when measured) and brighter: demosaicing's cost, which the wheel does not pay.
  const double m = fit["lobes"][1]["m"].get<double>();
  std::printf("Bayer clear coat: m %.4f (truth 0.0200), ks %.4f %.4f %.4f (truth 0.15)\n", m,
              fit["lobes"][1]["ks"][0].get<double>(), fit["lobes"][1]["ks"][1].get<double>(),
              fit["lobes"][1]["ks"][2].get<double>());
  EXPECT_GT(m, 0.0205);
  EXPECT_LT(m, 0.025);
}
