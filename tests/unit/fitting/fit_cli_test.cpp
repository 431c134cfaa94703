// paintlab fit / paintlab bin as a technician and a lab script see them: output files,
// messages, exit codes (0 ok, 1 the fit failed, 2 bad input), nothing written on failure.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <fmt/format.h>

#include "paintlab/acquisition/session.h"
#include "paintlab/acquisition/session_reader.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/brdf/pearlescent.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/fitting/hole_fill.h"
#include "paintlab/fitting/session_binning.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "synthetic.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

using test_support::blue_params;

TEST(FitCli, FitsAMerlFileAndWritesFitJson) {
  test::TempDir dir;
  const brdf::CookTorranceParams truth = blue_params();
  // A MERL file as public tables come: measured values, no statistics, with 1 %
  // multiplicative noise; one bin in 8 (the others missing, -1 in the file) keeps the test fast.
  brdf::MerlTable t = test_support::tabulate_sparse(brdf::CookTorrance(truth.kd, truth.lobes), 8);
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

// Issue 13: a hole-filled table (bin --fill) was fitted as if every bin were measured: over
// 120 s and 990 MB with no word. The coverage map beside it says which bins were filled;
// fit says so at once and fits the measured ones only (the same result as the unfilled table).
TEST(FitCli, AFilledTableIsFittedOnItsMeasuredBinsAndSaysSo) {
  test::TempDir dir;
  const brdf::CookTorranceParams truth = blue_params();
  brdf::MerlTable t = test_support::tabulate_sparse(brdf::CookTorrance(truth.kd, truth.lobes), 8);
  const std::size_t measured = t.count_in_state(brdf::BinState::Measured);
  const HoleFillReport filled = fill_holes(t);
  ASSERT_GT(filled.filled_mirror + filled.filled_pyramid, measured);  // most of the table is filled
  brdf::write_merl(dir / "blue.binary", t);
  write_coverage_exr(coverage_map_path_for(dir / "blue.binary"), t);
  ASSERT_TRUE(fs::exists(dir / "blue.coverage.exr"));
  const auto r = test::run_paintlab("fit " + (dir / "blue.binary").string() + " --lobes 2 --out " +
                                    (dir / "fit.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr(fmt::format("{} of its", filled.filled_mirror + filled.filled_pyramid)));
  EXPECT_THAT(r.err, HasSubstr("filled bins are not measurements, so the fit uses the " + std::to_string(measured) +
                               " measured ones"));
  const Json j = read_json_file(dir / "fit.json");
  EXPECT_EQ(j["input"]["filled_bins_left_out"].get<std::size_t>(), filled.filled_mirror + filled.filled_pyramid);
  EXPECT_LE(j["residual"]["bins_used"].get<std::size_t>(), measured);  // no filled bin among them
  EXPECT_THAT(j["lobes"][1]["m"].get<double>(), test::NearRel(0.02, 0.01));

  // A coverage map of another table is refused, not trusted.
  brdf::MerlTable other = test_support::tabulate_sparse(brdf::CookTorrance(truth.kd, truth.lobes), 64);
  brdf::write_merl(dir / "other.binary", other);
  fs::copy_file(dir / "blue.coverage.exr", dir / "other.coverage.exr");
  const auto o = test::run_paintlab("fit " + (dir / "other.binary").string() + " --out " + (dir / "o.json").string());
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_THAT(o.err, HasSubstr("other.coverage.exr: marks bin"));
  EXPECT_FALSE(fs::exists(dir / "o.json"));
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
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --min-samples some --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--min-samples: 'some' is neither auto nor a count from 1 to 100000"));
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --model phong --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("unknown model 'phong'"));
  r = test::run_paintlab("fit " + (dir / "missing.binary").string() + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(out));
  // A table does not say which pixel measured which colour.
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --cfa-sites on --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--cfa-sites on: " + (dir / "holes.binary").string() + " is a table"));
  r = test::run_paintlab("fit " + (dir / "holes.binary").string() + " --cfa-sites always --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--cfa-sites"));
  EXPECT_FALSE(fs::exists(out));
}

// A fit stopped at its iteration limit is written all the same, with "converged": false and
// the solver's termination, and the command exits 1 (issue 13); readers of such a fit.json
// (export, library add) accept it and say so.
TEST(FitCli, AFitThatDoesNotConvergeIsWrittenAndExitsOne) {
  test::TempDir dir;
  // A layered pearlescent paint is no sum of Cook-Torrance lobes; one iteration cannot converge.
  brdf::write_merl(dir / "pearl.binary",
                   test_support::tabulate_sparse(brdf::LayeredPearlescent(test_support::white_pearl()), 16));
  const std::string out = (dir / "fit.json").string();
  const auto r = test::run_paintlab("fit " + (dir / "pearl.binary").string() + " --max-iterations 1 --out " + out);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("did not converge"));
  EXPECT_THAT(r.err, HasSubstr("NO_CONVERGENCE"));
  EXPECT_THAT(r.err, HasSubstr("\"converged\": false"));
  EXPECT_THAT(r.out, HasSubstr("NOT converged"));
  ASSERT_TRUE(fs::exists(out));
  const Json j = read_json_file(out);
  EXPECT_FALSE(j["summary"]["converged"].get<bool>());
  EXPECT_THAT(j["summary"]["termination"].get<std::string>(), HasSubstr("NO_CONVERGENCE"));
  EXPECT_EQ(j["summary"]["iterations"].get<int>(), 1);
  EXPECT_EQ(j["lobes"].size(), 3u);
  EXPECT_NO_THROW(brdf::paint_from_json(j, "fit.json"));
  // Export from it: written, the file records it, a warning, exit 0 (the fit already exited 1).
  const std::string axf = (dir / "pearl.axf.h5").string();
  const auto e = test::run_paintlab("export " + out + " --axf " + axf);
  EXPECT_EQ(e.exit_code, 0) << e.out << e.err;
  EXPECT_THAT(e.err, HasSubstr("did not converge"));
  ASSERT_TRUE(fs::exists(axf));
  const auto show = test::run_paintlab("axf show " + axf);
  EXPECT_THAT(show.out, HasSubstr("did NOT converge"));
  // The library takes it, and says so.
  const auto l = test::run_paintlab("library add --dir " + (dir / "lib").string() + " " + out);
  EXPECT_EQ(l.exit_code, 0) << l.out << l.err;
  EXPECT_THAT(l.err, HasSubstr("did not converge"));
}

test_support::SimSessionOptions small_sweep() {
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.step_deg = 6.0;
  o.sparkle = false;
  return o;
}

TEST(FitCli, BinsAndFitsASessionFolder) {
  const brdf::PaintSpec spec = brdf::load_paint_file(test::source_dir() / "paints/solid-blue.toml");
  const auto sim = test_support::make_sim_session(sim::sim_paint(spec), small_sweep());
  const fs::path session = sim->dir / "session";
  test_support::write_session_folder(*sim, session, "Solid Blue #2");
  const std::string calib = " --calib " + sim->calibration_dir().string();
  const fs::path merl = sim->dir / "blue.binary";
  auto r = test::run_paintlab("bin " + session.string() + calib + " --out " + merl.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr(std::to_string(sim->frames.size()) + " images"));
  EXPECT_THAT(r.out, HasSubstr("glossy"));
  ASSERT_TRUE(fs::exists(sim->dir / "blue.coverage.exr"));
  const ExrImage cov = read_exr(sim->dir / "blue.coverage.exr");
  EXPECT_NE(cov.find("count"), nullptr);
  EXPECT_NE(cov.find("state"), nullptr);
  const brdf::MerlTable table = brdf::read_merl(merl);
  const std::size_t measured = table.count_in_state(brdf::BinState::Measured);
  EXPECT_GT(measured, 10000u);
  EXPECT_LT(measured, brdf::kMerlBins / 2);  // holes stay holes (-1 in the file)
  // What `bin` writes, `fit` reads with the coverage map beside it: every bin the map calls
  // measured is measured in the file (a mean below zero is written as 0, not as missing).
  r = test::run_paintlab("fit " + merl.string() + " --lobes 1 --out " + (sim->dir / "table.fit.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(sim->dir / "table.fit.json"));
  // Against the paint it is, band by band of max(theta_i, theta_o) (docs/fitting.md).
  const fs::path merl2 = sim->dir / "blue2.binary";
  const std::string paint_file = (test::source_dir() / "paints/solid-blue.toml").string();
  r = test::run_paintlab("bin " + session.string() + calib + " --out " + merl2.string() + " --against " + paint_file);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("measured against the paint by max(theta_i, theta_o)"));
  EXPECT_THAT(r.out, HasSubstr("85-90  deg"));
  EXPECT_THAT(r.out, HasSubstr("0 next to invalid"));
  r = test::run_paintlab("bin " + session.string() + calib + " --out " + (sim->dir / "x.binary").string() +
                         " --against " + (sim->dir / "missing.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("missing.toml"));
  EXPECT_FALSE(fs::exists(sim->dir / "x.binary"));
  r = test::run_paintlab("bin " + session.string() + calib + " --out " + (sim->dir / "x.binary").string() +
                         " --blur-px 11");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--blur-px"));

  const fs::path out = sim->dir / "fit.json";
  // Not a Bayer camera's session: no filter-array sites to fit at (the default, auto, fits
  // the image as it is).
  r = test::run_paintlab("fit " + session.string() + calib + " --lobes 2 --cfa-sites on --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("cannot be fitted at its filter-array sites (--cfa-sites on)"));
  EXPECT_FALSE(fs::exists(out));
  r = test::run_paintlab("fit " + session.string() + calib + " --lobes 2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("cook-torrance, 2 lobes"));
  const Json j = read_json_file(out);
  EXPECT_EQ(j["name"], "solid-blue--2");  // from the session's sample name
  EXPECT_EQ(j["input"]["kind"], "session");
  EXPECT_EQ(j["input"]["positions"].get<std::size_t>(), sim->frames.size());
  EXPECT_EQ(j["input"]["coverage"]["total"]["measured_bins"].get<std::size_t>(), measured);
  EXPECT_EQ(j["residual"]["noise_source"], "sample-noise");
  // A solid paint: a point per bin (auto pooling), and the glossy samples' spread said.
  EXPECT_EQ(j["residual"]["min_samples"], 1);
  EXPECT_LT(j["residual"]["sparkle_excess"].get<double>(), kSparkleExcess);
  EXPECT_THAT(r.out, HasSubstr("fit points        a point per bin (glossy samples spread"));
  EXPECT_THAT(r.out, Not(HasSubstr("the session sparkles")));  // no flakes, no note about their draw
  // The extraction rules it was binned with: no blur in this calibration, the 2 px margin.
  EXPECT_EQ(j["input"]["blur_sigma_px"].get<double>(), 0.0);
  EXPECT_EQ(j["input"]["valid_margin_px"].get<int>(), 2);
  EXPECT_FALSE(j["input"].contains("cfa_sites"));
  const brdf::PaintSpec fitted = brdf::paint_from_json(j, "fit.json");
  const auto* truth = spec.cook_torrance();
  const auto* ct = fitted.cook_torrance();
  ASSERT_NE(ct, nullptr);
  ASSERT_NE(truth, nullptr);
  // A 100-pixel sphere every 6 degrees: the whole-pipeline accuracy is
  // tests/integration/fitting/sim_pipeline_test.cpp's.
  for (int c = 0; c < 3; ++c) EXPECT_THAT(ct->kd[c], test::NearRel(truth->kd[c], 0.03)) << c;
  EXPECT_THAT(ct->lobes[1].m, test::NearRel(truth->lobes[1].m, 0.03));
  EXPECT_TRUE(j["residual"]["point_scatter"].is_null());  // the default log correction: the samples' spread
  // --log-correction scatter: the fit points of a solid paint's independent samples scatter as
  // their spread says (factor near 1), and the fit is the same paint.
  const fs::path scatter_out = sim->dir / "scatter.json";
  r = test::run_paintlab("fit " + session.string() + calib + " --lobes 2 --log-correction scatter --out " +
                         scatter_out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json js = read_json_file(scatter_out);
  ASSERT_TRUE(js["residual"]["point_scatter"].is_number());
  EXPECT_GE(js["residual"]["point_scatter"].get<double>(), 1.0);
  EXPECT_LT(js["residual"]["point_scatter"].get<double>(), 1.5);
  const brdf::PaintSpec scatter_fit = brdf::paint_from_json(js, "scatter.json");
  const auto* cs = scatter_fit.cook_torrance();
  ASSERT_NE(cs, nullptr);
  for (int c = 0; c < 3; ++c) EXPECT_THAT(cs->kd[c], test::NearRel(ct->kd[c], 0.01)) << c;
  r = test::run_paintlab("fit " + session.string() + calib + " --log-correction points --out " +
                         (sim->dir / "bad.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--log-correction: 'points' is neither spread nor scatter"));
  EXPECT_FALSE(fs::exists(sim->dir / "bad.json"));
}

// Several sessions of one paint (other spheres, or the sphere turned on its stand) are binned
// into one table and fitted together: every session's samples in the same bins. Here the same
// images twice under two sample names: every bin twice the samples at the same mean.
TEST(SessionBinning, SeveralSessionsOfOnePaintFillOneTableAndEachIsRecorded) {
  const brdf::PaintSpec spec = brdf::load_paint_file(test::source_dir() / "paints/solid-blue.toml");
  const auto sim = test_support::make_sim_session(sim::sim_paint(spec), small_sweep());
  const fs::path a = sim->dir / "a", b = sim->dir / "b";
  test_support::write_session_folder(*sim, a, "Solid Blue #2");
  test_support::write_session_folder(*sim, b, "Solid Blue #2 turned");
  SessionBinOptions o;
  o.calib_dir = sim->calibration_dir();
  const BinnedSession one = bin_session(acq::SessionDir::open(a), o);
  const BinnedSession two = bin_sessions({acq::SessionDir::open(a), acq::SessionDir::open(b)}, o);
  EXPECT_EQ(two.stats.samples, 2 * one.stats.samples);
  ASSERT_GT(one.binned.table.count_in_state(brdf::BinState::Measured), 10000u);
  std::size_t checked = 0;
  for (std::size_t bin = 0; bin < brdf::kMerlBins; ++bin) {
    if (one.binned.table.count(bin) == 0) continue;
    ASSERT_EQ(two.binned.table.count(bin), 2 * one.binned.table.count(bin)) << bin;
    for (int c = 0; c < 3; ++c) ASSERT_THAT(two.binned.table.value(bin)[c], test::NearRel(one.binned.table.value(bin)[c], 1e-5));
    ++checked;
  }
  EXPECT_EQ(checked, one.binned.table.count_in_state(brdf::BinState::Measured));
  // What fit.json records: each session, its checksum and positions; the sums at the top.
  EXPECT_EQ(two.input["kind"], "sessions");
  ASSERT_EQ(two.input["sessions"].size(), 2u);
  EXPECT_EQ(two.input["sessions"][1]["sample"], "Solid Blue #2 turned");
  EXPECT_EQ(two.input["sessions"][1]["session_sha256"], acq::session_sha256(b));
  EXPECT_EQ(two.input["sessions"][0]["positions"].get<std::size_t>(), sim->frames.size());
  EXPECT_EQ(two.input["positions"].get<std::size_t>(), 2 * sim->frames.size());
  EXPECT_EQ(two.input["extraction"]["samples"].get<std::uint64_t>(), two.stats.samples);
  EXPECT_EQ(two.input["sessions"][0]["extraction"]["samples"].get<std::uint64_t>(), one.stats.samples);
  EXPECT_EQ(fitted_sessions(two.input), (std::vector<fs::path>{fs::absolute(a), fs::absolute(b)}));
  EXPECT_EQ(fitted_sessions(one.input), std::vector<fs::path>{fs::absolute(a)});
}

// The same through the command line: `fit`, `bin` and `export --merl` of two sessions, and
// what cannot be fitted together refused with nothing written.
TEST(FitCli, FitsSeveralSessionsOfOnePaintTogether) {
  const brdf::PaintSpec spec = brdf::load_paint_file(test::source_dir() / "paints/solid-blue.toml");
  const auto sim = test_support::make_sim_session(sim::sim_paint(spec), small_sweep());
  const fs::path a = sim->dir / "a", b = sim->dir / "b", srgb = sim->dir / "srgb";
  test_support::write_session_folder(*sim, a, "Solid Blue #2");
  test_support::write_session_folder(*sim, b, "Solid Blue #2 turned");
  test_support::write_session_folder(*sim, srgb, "Solid Blue #2", 0, "linear sRGB (D65)");
  const std::string calib = " --calib " + sim->calibration_dir().string();
  const fs::path out = sim->dir / "fit.json";
  auto r = test::run_paintlab("fit " + a.string() + " " + b.string() + calib + " --lobes 2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("measured sample 'Solid Blue #2 turned'"));  // warned: fitted as one paint
  EXPECT_THAT(r.out, HasSubstr(fmt::format("{} images", 2 * sim->frames.size())));
  const Json j = read_json_file(out);
  EXPECT_EQ(j["input"]["kind"], "sessions");
  ASSERT_EQ(j["input"]["sessions"].size(), 2u);
  EXPECT_EQ(j["name"], "solid-blue--2");  // the first session's sample
  EXPECT_EQ(j["residual"]["min_samples"], 1);  // no sparkle: a point per bin, however many sessions
  const brdf::PaintSpec fitted = brdf::paint_from_json(j, "fit.json");
  ASSERT_NE(fitted.cook_torrance(), nullptr);
  for (int c = 0; c < 3; ++c)
    EXPECT_THAT(fitted.cook_torrance()->kd[c], test::NearRel(spec.cook_torrance()->kd[c], 0.03)) << c;
  // `paintlab bin` takes several sessions as well: the same images twice give the values of
  // one (SessionBinning above counts the samples).
  const fs::path binned = sim->dir / "two.binary", single = sim->dir / "one.binary";
  r = test::run_paintlab("bin " + a.string() + " " + b.string() + calib + " --out " + binned.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(sim->dir / "two.coverage.exr"));
  r = test::run_paintlab("bin " + a.string() + calib + " --out " + single.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const brdf::MerlTable bin_table = brdf::read_merl(binned), one_table = brdf::read_merl(single);
  ASSERT_GT(one_table.count_in_state(brdf::BinState::Measured), 10000u);
  for (std::size_t bin = 0; bin < brdf::kMerlBins; bin += 97)
    ASSERT_THAT(bin_table.value(bin)[1], test::NearRel(one_table.value(bin)[1], 1e-5)) << bin;
  // export --merl bins the fit's sessions again, both of them.
  const fs::path merl = sim->dir / "both.binary";
  r = test::run_paintlab("export " + out.string() + calib + " --merl " + merl.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const brdf::MerlTable exported = brdf::read_merl(merl);
  for (std::size_t bin = 0; bin < brdf::kMerlBins; bin += 97)  // measured bins (export fills the holes)
    if (bin_table.value(bin)[1] >= 0.0) {
      ASSERT_THAT(exported.value(bin)[1], test::NearRel(bin_table.value(bin)[1], 1e-5)) << bin;
    }

  // What cannot be fitted together, nothing written.
  const fs::path bad = sim->dir / "bad.json";
  r = test::run_paintlab("fit " + a.string() + " " + a.string() + calib + " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("given twice"));
  r = test::run_paintlab("fit " + a.string() + " " + merl.string() + calib + " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr(merl.string() + ": not a session folder"));
  r = test::run_paintlab("fit " + a.string() + " " + srgb.string() + calib + " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("need one colour space"));
  r = test::run_paintlab("fit " + a.string() + " " + b.string() + calib + " --flakes " +
                         (sim->dir / "flakes.json").string() + " --out " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--flakes measures one session's flakes"));
  EXPECT_FALSE(fs::exists(bad));
  EXPECT_FALSE(fs::exists(sim->dir / "flakes.json"));
}

TEST(FitCli, SessionsWithMissingPositionsOrWithoutCalibrationAreRejected) {
  test_support::SimSessionOptions o = small_sweep();
  o.step_deg = 45.0;
  const auto sim = test_support::make_sim_session(sim::sim_paint(brdf::load_paint_file(
                                                      test::source_dir() / "paints/solid-blue.toml")),
                                                  o);
  const fs::path session = sim->dir / "session";
  test_support::write_session_folder(*sim, session, "Solid Blue #2", 2);
  const fs::path out = sim->dir / "fit.json", merl = sim->dir / "t.binary";
  const std::string calib = " --calib " + sim->calibration_dir().string();
  auto r = test::run_paintlab("fit " + session.string() + calib + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("2 of 7 light positions are missing (index 5, 6)"));
  EXPECT_THAT(r.err, HasSubstr("paintlab measure --resume"));
  r = test::run_paintlab("bin " + session.string() + calib + " --out " + merl.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("missing"));
  // A complete session whose rig file is unknown needs --calib.
  const fs::path complete = sim->dir / "complete";
  test_support::write_session_folder(*sim, complete, "Solid Blue #2");
  r = test::run_paintlab("bin " + complete.string() + " --out " + merl.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--calib"));
  // A folder that is no session.
  r = test::run_paintlab("bin " + sim->calibration_dir().string() + " --out " + merl.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("not a session folder"));
  r = test::run_paintlab("fit " + complete.string() + calib + " --variance sideways --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--variance"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(merl));
  EXPECT_FALSE(fs::exists(sim->dir / "t.coverage.exr"));
}

}  // namespace
}  // namespace paintlab::fit
