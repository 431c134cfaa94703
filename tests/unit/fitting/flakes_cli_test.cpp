// paintlab flakes, export --flakes, axf show and render with measured flakes, as a
// technician and a lab script see them: files, messages, exit codes, nothing written on bad
// input. Their own target, labelled slow: each runs the paintlab binary's fits and renders
// (minutes under the sanitizers); the code they reach runs under the sanitizers through
// flakes_test.cpp and the AxF-like file tests.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;

// A session of the silver metallic every 6 deg (320 x 240) as `paintlab measure` leaves it.
struct CliSession {
  std::unique_ptr<test_support::SimSession> sim;
  std::filesystem::path paint, session;
  std::string calib;
};
CliSession cli_session() {
  CliSession c;
  c.paint = test::source_dir() / "paints" / "silver-metallic.toml";
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 25.0;
  o.step_deg = 6.0;
  o.start_deg = 30.0;
  o.stop_deg = 150.0;
  c.sim = test_support::make_sim_session(sim::sim_paint(brdf::load_paint_file(c.paint)), o);
  c.session = c.sim->dir / "session";
  test_support::write_session_folder(*c.sim, c.session, "Silver 7", 0, colour::kLinearSrgb);
  c.calib = " --calib " + c.sim->calibration_dir().string();
  return c;
}

// `paintlab flakes` against the paint file, into the session's flakes.json.
test::RunResult flakes_against_paint(const CliSession& c, const std::filesystem::path& out) {
  return test::run_paintlab("flakes " + c.session.string() + c.calib + " --fit " + c.paint.string() + " --out " +
                            out.string());
}

TEST(FlakesCli, WritesFlakesJsonAndRefusesBadInput) {
  namespace fs = std::filesystem;
  const CliSession c = cli_session();
  const auto& sim = c.sim;
  const fs::path& session = c.session;
  const std::string& calib = c.calib;
  const fs::path out = sim->dir / "flakes.json";
  // Against the paint file, and against a fit made now.
  auto r = flakes_against_paint(c, out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("21 images"));
  EXPECT_THAT(r.out, HasSubstr("instrument-style sparkle"));
  EXPECT_THAT(r.out, HasSubstr("wrote " + out.string()));
  const FlakeStats s = flakes_from_json(read_json_file(out), out.string());
  EXPECT_GT(s.glints, 200u);
  EXPECT_EQ(s.colour_space, colour::kLinearSrgb);
  EXPECT_EQ(s.options.num_theta_f, 12);
  const fs::path out2 = sim->dir / "flakes-fit-now.json";
  r = test::run_paintlab("flakes " + session.string() + calib + " --lobes 3 --slices 10 --out " + out2.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("fitting a 3-lobe Cook-Torrance model"));
  const FlakeStats s2 = flakes_from_json(read_json_file(out2), out2.string());
  EXPECT_EQ(s2.options.num_theta_i, 10);
  // The fitted model is close to the paint: about as many glints.
  EXPECT_NEAR(static_cast<double>(s2.glints), static_cast<double>(s.glints), 0.2 * static_cast<double>(s.glints));

  // `paintlab fit --flakes`: the flakes against the fit it made, as `flakes --fit fit.json`.
  const fs::path fit_json = sim->dir / "fit.json", out3 = sim->dir / "flakes-of-fit.json";
  r = test::run_paintlab("fit " + session.string() + calib + " --out " + fit_json.string() + " --flakes " + out3.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("instrument-style sparkle"));
  EXPECT_THAT(r.out, HasSubstr("wrote " + out3.string()));
  // The fit says what its +- do not count under sparkle.
  EXPECT_THAT(r.out, HasSubstr("the session sparkles: the +- count the samples as independent"));
  const fs::path out4 = sim->dir / "flakes-against-fit.json";
  r = test::run_paintlab("flakes " + session.string() + calib + " --fit " + fit_json.string() + " --out " + out4.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const FlakeStats s3 = flakes_from_json(read_json_file(out3), out3.string());
  EXPECT_EQ(s3, flakes_from_json(read_json_file(out4), out4.string()));
  EXPECT_NEAR(static_cast<double>(s3.glints), static_cast<double>(s.glints), 0.2 * static_cast<double>(s.glints));
  // --flakes never over --out or an input, and only for a session.
  const fs::path bad_fit = sim->dir / "bad-fit.json";
  r = test::run_paintlab("fit " + session.string() + calib + " --out " + bad_fit.string() + " --flakes " + bad_fit.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--flakes"));
  r = test::run_paintlab("fit " + fit_json.string() + " --out " + bad_fit.string() + " --flakes " + out4.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(bad_fit));

  // Bad input: nothing written.
  const fs::path bad = sim->dir / "bad.json";
  r = test::run_paintlab("flakes " + session.string() + calib + " --slices 16 --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--slices"));
  r = test::run_paintlab("flakes " + (sim->dir / "nothing").string() + " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("nothing"));
  r = test::run_paintlab("flakes " + session.string() + calib + " --fit " + (sim->dir / "missing.json").string() +
                         " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("missing.json"));
  EXPECT_FALSE(fs::exists(bad));
  // Never over an input.
  r = test::run_paintlab("flakes " + session.string() + calib + " --fit " + out.string() + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
}


TEST(FlakesCli, ExportsTheFlakesWithThePaintAndRendersThem) {
  namespace fs = std::filesystem;
  const CliSession c = cli_session();
  const auto& sim = c.sim;
  const fs::path& paint = c.paint;
  const fs::path& session = c.session;
  const std::string& calib = c.calib;
  const fs::path out = sim->dir / "flakes.json";
  auto r = flakes_against_paint(c, out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const FlakeStats s = flakes_from_json(read_json_file(out), out.string());
  // Export with the flakes measured against the fit made there, and with a flakes.json.
  const fs::path axf = sim->dir / "silver.axf.h5";
  r = test::run_paintlab("export " + session.string() + calib + " --axf " + axf.string() + " --flakes auto");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("flake BTF of"));
  const AxfPaint exported = read_axf_file(axf);
  ASSERT_TRUE(exported.flake_stats && exported.flake_btf);
  EXPECT_GT(exported.flake_btf->slices(), 0);
  EXPECT_NEAR(static_cast<double>(exported.flake_stats->glints), static_cast<double>(s.glints), 0.2 * static_cast<double>(s.glints));
  // Rendered with its flakes (and without), and compared with the session at 90 deg.
  const fs::path png = sim->dir / "p.png", plain = sim->dir / "plain.png";
  r = test::run_paintlab("render " + axf.string() + " --size 128 --out " + png.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_paintlab("render " + axf.string() + " --size 128 --no-sparkle --out " + plain.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_file(png), read_file(plain));
  r = test::run_paintlab("render " + axf.string() + " --out " + (sim->dir / "c.png").string() + " --compare " +
                         session.string() + calib + " --angle 90");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("sparkle (glints against the smooth model): measured"));
  EXPECT_THAT(r.out, HasSubstr("area measured / rendered"));
  r = test::run_paintlab("axf show " + axf.string());
  EXPECT_THAT(r.out, HasSubstr("measured flakes: sparkle area"));
  EXPECT_THAT(r.out, HasSubstr("flake BTF:"));
  const fs::path axf2 = sim->dir / "from-paint.axf.h5";
  r = test::run_paintlab("export " + paint.string() + " --axf " + axf2.string() + " --flakes " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(*read_axf_file(axf2).flake_stats, s);
  r = test::run_paintlab("export " + paint.string() + " --axf " + (sim->dir / "x.axf.h5").string() + " --flakes auto");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--flakes auto measures the flakes of a session"));
  EXPECT_FALSE(fs::exists(sim->dir / "x.axf.h5"));

}

}  // namespace
}  // namespace paintlab::fit
