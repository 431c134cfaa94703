// paintlab fit / paintlab bin as a technician and a lab script see them: output files,
// messages, exit codes (0 ok, 1 the fit failed, 2 bad input), nothing written on failure.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/brdf/pearlescent.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/json.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

brdf::CookTorranceParams blue() {
  brdf::CookTorranceParams p;
  p.kd = brdf::Rgb(0.030, 0.060, 0.300);
  p.lobes = {{brdf::Rgb(0.010, 0.010, 0.010), 0.30, 0.04}, {brdf::Rgb(0.15, 0.15, 0.15), 0.02, 0.04}};
  return p;
}

TEST(FitCli, FitsAMerlFileAndWritesFitJson) {
  test::TempDir dir;
  const brdf::CookTorranceParams truth = blue();
  // A MERL file as public tables come: every bin, measured, no statistics; with 1 %
  // multiplicative noise.
  brdf::MerlTable t = brdf::tabulate(brdf::CookTorrance(truth.kd, truth.lobes));
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> g(0, 1);
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b)
    if (t.state(b) == brdf::BinState::Measured) t.set_value(b, t.value(b) * (1 + 0.01 * g(rng)), brdf::BinState::Measured);
  brdf::write_merl(dir / "Solid Blue.binary", t);
  const auto r = test::run_paintlab("fit '" + (dir / "Solid Blue.binary").string() + "' --model cook-torrance --lobes 2 --out " +
                                    (dir / "fit.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("cook-torrance, 2 lobes"));
  EXPECT_THAT(r.out, HasSubstr("residual log-RMS"));
  EXPECT_THAT(r.out, HasSubstr("peak"));
  const Json j = read_json_file(dir / "fit.json");
  EXPECT_EQ(j["model"], "cook-torrance");
  EXPECT_EQ(j["name"], "solid-blue");
  ASSERT_EQ(j["lobes"].size(), 2u);
  EXPECT_GT(j["lobes"][0]["m"].get<double>(), j["lobes"][1]["m"].get<double>());  // broadest first
  EXPECT_TRUE(j["residual"].contains("log_rms"));
  EXPECT_TRUE(j["residual"].contains("bins_used"));
  EXPECT_EQ(j["stddev"]["lobes"].size(), 2u);
  EXPECT_TRUE(j["summary"]["converged"].get<bool>());
  EXPECT_EQ(j["input"]["kind"], "merl");
  // The fit object reads back as a paint, close to the truth.
  const brdf::PaintSpec spec = brdf::paint_from_json(j, "fit.json");
  const auto* ct = spec.cook_torrance();
  ASSERT_NE(ct, nullptr);
  for (int c = 0; c < 3; ++c) EXPECT_THAT(ct->kd[c], test::NearRel(truth.kd[c], 0.01));
  EXPECT_THAT(ct->lobes[1].m, test::NearRel(0.02, 0.01));
}

TEST(FitCli, BadInputFailsWithoutWritingAnything) {
  test::TempDir dir;
  const std::string out = (dir / "fit.json").string();
  // A MERL file of the wrong size.
  write_file_atomic(dir / "short.binary", std::string(1000, '\0'));
  auto r = test::run_paintlab("fit " + (dir / "short.binary").string() + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("expected 34992012 bytes, got 1000"));
  EXPECT_FALSE(fs::exists(out));
  // A table that is all holes.
  brdf::write_merl(dir / "holes.binary", brdf::MerlTable{});
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("no measured bins"));
  EXPECT_FALSE(fs::exists(out));
  // Nonsense options.
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --lobes 4 --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("lobes"));
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --model phong --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("unknown model 'phong'"));
  r = test::run_paintlab("fit " + (dir / "missing.binary").string() + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(out));
}

TEST(FitCli, AFitThatDoesNotConvergeExitsOneWithoutOutput) {
  test::TempDir dir;
  // A layered pearlescent paint is no sum of Cook-Torrance lobes; one iteration cannot converge.
  brdf::PearlescentParams p;
  p.substrate = brdf::Rgb(0.85, 0.85, 0.87);
  p.gloss_roughness = 0.03;
  p.coverage = 0.9;
  p.opacity = 0.15;
  p.flake_roughness = 0.18;
  p.film_ior = 2.5;
  p.film_thickness_nm = 160;
  brdf::write_merl(dir / "pearl.binary", brdf::tabulate(brdf::LayeredPearlescent(p)));
  const std::string out = (dir / "fit.json").string();
  const auto r = test::run_paintlab("fit " + (dir / "pearl.binary").string() + " --max-iterations 1 --out " + out);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("did not converge"));
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace paintlab::fit
