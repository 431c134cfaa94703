// `paintlab demo --quick` as a technician runs it first: the simulated rig end to end. The
// run must succeed, write DIR/summary.json in the shape of DESIGN.md's contract, leave a
// valid AxF-like file, a MERL table, a library with the paint and the previews, and the
// fit must be close to the paint the simulator measured.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>

#include "colour_accuracy.h"
#include "report_browser.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

double rel(double fit, double truth) { return std::abs(fit - truth) / std::abs(truth); }

// Runs `paintlab demo --quick ARGS --out OUT`, which must succeed, prints its summary table
// and returns its output.
std::string quick_demo(const std::string& args, const fs::path& out) {
  auto r = test::run_paintlab("demo --quick " + args + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto table = r.out.find("== paintlab demo");
  std::cout << (table == std::string::npos ? r.out : r.out.substr(table)) << "\n";
  return r.out;
}

}  // namespace

TEST(DemoCli, QuickDemoWritesTheContractSummaryAndAFitCloseToTheTruth) {
  test::TempDir dir;
  const fs::path out = dir / "demo";
  const std::string output = quick_demo("", out);
  ASSERT_FALSE(HasFailure());
  EXPECT_THAT(output, HasSubstr("$ paintlab calibrate all"));
  EXPECT_THAT(output, HasSubstr("demo finished in"));

  const Json s = read_json_file(out / "summary.json");
  // The contract's keys.
  EXPECT_EQ(s.at("paint"), "silver-metallic");
  for (const char* k : {"truth", "fit", "calibration", "timings_s", "files"}) ASSERT_TRUE(s.contains(k)) << k;
  EXPECT_EQ(s["fit"].at("model"), "cook-torrance");
  for (const char* k : {"kd", "lobes", "residual"}) ASSERT_TRUE(s["fit"].contains(k)) << k;
  EXPECT_TRUE(s["fit"]["residual"].contains("log_rms"));
  EXPECT_GT(s["fit"]["residual"].value("bins_used", 0), 100);
  for (const char* k : {"reprojection_rms_px", "focal_error_rel", "sphere_centre_error_mm", "light_angle_error_deg",
                        "response_error_rel"})
    ASSERT_TRUE(s["calibration"].contains(k)) << k;
  for (const char* k : {"calibrate", "measure", "fit", "export", "total"})
    ASSERT_TRUE(s["timings_s"].contains(k) && s["timings_s"][k].get<double>() > 0) << k;
  for (const char* k : {"axf", "merl", "fit", "preview", "report", "flakes"}) {
    ASSERT_TRUE(s["files"].contains(k)) << k;
    EXPECT_TRUE(fs::exists(s["files"][k].get<std::string>())) << k;
  }
  // The silver metallic sparkles: its flakes measured and exported with the paint (docs/sparkle.md).
  ASSERT_TRUE(s.contains("sparkle"));
  EXPECT_FALSE(s["sparkle"]["empty"].get<bool>());
  EXPECT_GT(s["sparkle"]["area"].get<double>(), 0.005);
  EXPECT_GT(s["sparkle"]["lifetime_deg"].get<double>(), 0.0);
  EXPECT_EQ(s["sparkle"]["instrument"].size(), 3u);
  // The demo's report in a real browser, with no network (docs/reports.md).
  report_browser::check_demo_report(out);

  // The calibration on the simulated rig (half resolution) against its truth.
  const Json& c = s["calibration"];
  EXPECT_LT(c["reprojection_rms_px"].get<double>(), 0.25);
  EXPECT_LT(std::abs(c["focal_error_rel"].get<double>()), 0.002);
  // A 50 mm lens leaves the principal point loose (the calibration says how loose); the
  // sphere centre then moves sideways with it. Its distance follows the focal length
  // (1.2 m x the focal error) plus the silhouette's own error.
  EXPECT_LT(c["principal_point_error_px"].get<double>(), 3.0 * c["principal_point_std_px"].get<double>());
  EXPECT_LT(std::abs(c["sphere_distance_error_mm"].get<double>()),
            1200.0 * std::abs(c["focal_error_rel"].get<double>()) + 0.3);
  EXPECT_LT(c["light_angle_error_deg"].get<double>(), 0.2);
  EXPECT_LT(c["response_error_rel"].get<double>(), 0.02);

  // The fit against the paint, in colour: the demo's camera is a BayerRG16 colour camera with
  // a channel mix unlike sRGB under a warm LED, so R, G, B come out in linear sRGB and the
  // truth is the paint's own RGB. The diffuse term and the broad metallic lobe per channel;
  // the clear coat (a highlight 2-3 px across at half resolution), fitted at the filter-array
  // sites as `paintlab fit` does for a Bayer camera by default: m +3.4 %, ks +2..+9 % in this
  // run (on the demosaiced image m +21 %, ks -6 %; docs/colour.md).
  // (The medium lobe, the silver's sparkle, trades ks against F0 on the 19 light positions of
  // --quick; the full demo reports it.)
  EXPECT_EQ(s["camera"], "BayerRG16");
  EXPECT_FALSE(s.contains("truth_seen_by_camera"));
  // The measurement as a paint lab reads it: CIELAB at the five angles, of the paint, of the
  // samples nearest each and of the fit. Away from the gloss both are within dE00 1 of the
  // paint (0.2-0.6 measured, 0.01-0.2 fitted in this run); near it the silver's sparkle
  // defeats the few samples of the quick rig and pulls the fit's flake lobe down (docs/colour.md).
  ASSERT_TRUE(s.contains("colour"));
  ASSERT_EQ(s["colour"]["geometries"].size(), 5u);
  EXPECT_THAT(output, HasSubstr("five-angle CIELAB"));
  for (int i = 2; i < 5; ++i) {
    const Json& g = s["colour"]["geometries"][i];
    SCOPED_TRACE(g["name"].get<std::string>());
    EXPECT_LT(g["measured_de00"].get<double>(), 1.0);
    EXPECT_LT(g["fit_de00"].get<double>(), 1.0);
  }
  EXPECT_THAT(output, HasSubstr("R, G, B in linear sRGB (D65)"));
  const Json& truth = s["truth"];
  const Json& fit = s["fit"];
  ASSERT_EQ(fit["lobes"].size(), truth["lobes"].size());
  EXPECT_EQ(fit["input"]["colour_space"], "linear sRGB (D65)");
  for (int ch = 0; ch < 3; ++ch) EXPECT_LT(rel(fit["kd"][ch], truth["kd"][ch]), 0.03) << "kd " << ch;
  EXPECT_LT(rel(fit["lobes"][0]["m"], truth["lobes"][0]["m"]), 0.02);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_LT(rel(fit["lobes"][0]["ks"][ch], truth["lobes"][0]["ks"][ch]), 0.05) << "lobe 1 ks " << ch;
    EXPECT_LT(rel(fit["lobes"][2]["ks"][ch], truth["lobes"][2]["ks"][ch]), 0.15) << "lobe 3 ks " << ch;
  }
  EXPECT_EQ(fit["input"]["cfa_sites"], true);
  EXPECT_LT(rel(fit["lobes"][2]["m"], truth["lobes"][2]["m"]), 0.08);

  // A red metallic (paints/red-metallic.toml, no sparkle) on the same calibrated rig, fitted as
  // `paintlab fit` does by default for a Bayer camera, at the filter-array sites (each colour
  // where its filter measured it; docs/fitting.md): kd, both lobes' ks per channel, m and r
  // within the colour issue's targets (3 %, 8 % for the clear coat's ks, m 2 %, r 5 %),
  // the clear coat's highlight 2-3 px across at this resolution included. The same session
  // fitted on its demosaiced image (--cfa-sites off): the clear coat comes out wider (+11 %
  // measured) and brighter, bilinear demosaicing's cost.
  {
    using colour_accuracy::relative_error;
    const auto [red, red_fit] = colour_accuracy::measure_and_fit(out, "red-metallic");
    ASSERT_TRUE(red_fit.contains("lobes"));
    EXPECT_EQ(red_fit["input"]["cfa_sites"], true);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_LT(relative_error(red_fit["kd"][ch], red["kd"][ch]), 0.03) << "kd " << ch;
      EXPECT_LT(relative_error(red_fit["lobes"][0]["ks"][ch], red["lobes"][0]["ks"][ch]), 0.03) << "ks " << ch;
      EXPECT_LT(relative_error(red_fit["lobes"][1]["ks"][ch], red["lobes"][1]["ks"][ch]), 0.08) << "clear coat ks " << ch;
    }
    for (int l = 0; l < 2; ++l) {
      EXPECT_LT(relative_error(red_fit["lobes"][l]["m"], red["lobes"][l]["m"]), 0.02) << "lobe " << l + 1 << " m";
      EXPECT_LT(relative_error(red_fit["lobes"][l]["r"], red["lobes"][l]["r"]), 0.05) << "lobe " << l + 1 << " r";
    }
    const Json demosaiced = colour_accuracy::fit_again(out, "red-metallic", 2, "--cfa-sites off", "demosaiced");
    ASSERT_TRUE(demosaiced.contains("lobes"));
    EXPECT_FALSE(demosaiced["input"].contains("cfa_sites"));
    const double m = demosaiced["lobes"][1]["m"].get<double>();
    EXPECT_GT(m, 0.0205);
    EXPECT_LT(m, 0.025);
  }

  // The files: the AxF-like file validates, the MERL table reads, the library lists the paint.
  EXPECT_EQ(test::run_paintlab("axf validate " + s["files"]["axf"].get<std::string>()).exit_code, 0);
  brdf::MerlTable table = brdf::read_merl(s["files"]["merl"].get<std::string>());
  EXPECT_LT(table.count_in_state(brdf::BinState::Empty), brdf::kMerlBins / 2);
  auto lib = test::run_paintlab("library list --dir " + (out / "library").string());
  EXPECT_EQ(lib.exit_code, 0) << lib.err;
  EXPECT_THAT(lib.out, HasSubstr("silver-metallic"));
}

// The demo's other colour camera: the monochrome camera behind the simulated filter wheel
// (calibrated through the wheel: scale per filter, the chart per filter). No demosaicing, so
// the clear coat's narrow highlight keeps its width (m +4 % here against +21 % for the Bayer
// camera at this resolution).
TEST(DemoCli, TheFilterWheelCameraMeasuresThePaintInColour) {
  test::TempDir dir;
  const fs::path out = dir / "demo";
  const std::string output = quick_demo("--camera wheel", out);
  ASSERT_FALSE(HasFailure());
  EXPECT_THAT(output, HasSubstr("filter wheel"));
  EXPECT_THAT(output, HasSubstr("== colour =="));
  const Json s = read_json_file(out / "summary.json");
  EXPECT_EQ(s["camera"], "Mono16 behind a filter wheel");
  EXPECT_TRUE(s.contains("colour"));
  const Json& truth = s["truth"];
  const Json& fit = s["fit"];
  EXPECT_EQ(fit["input"]["colour_space"], "linear sRGB (D65)");
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_LT(rel(fit["kd"][ch], truth["kd"][ch]), 0.03) << "kd " << ch;
    EXPECT_LT(rel(fit["lobes"][0]["ks"][ch], truth["lobes"][0]["ks"][ch]), 0.06) << "lobe 1 ks " << ch;
    EXPECT_LT(rel(fit["lobes"][2]["ks"][ch], truth["lobes"][2]["ks"][ch]), 0.06) << "lobe 3 ks " << ch;
  }
  EXPECT_LT(rel(fit["lobes"][0]["m"], truth["lobes"][0]["m"]), 0.02);
  EXPECT_LT(rel(fit["lobes"][2]["m"], truth["lobes"][2]["m"]), 0.08);
  // A deep blue solid and a red metallic (no sparkle) on the same calibrated rig: kd, the
  // flake lobe's and the clear coat's ks per channel, m and r of both lobes within the colour
  // issue's targets (3 %, 8 % for the clear coat's ks, m 2 %, r 5 %), but for the red's dark
  // green and blue kd (0.012 and 0.010 next to a red of 0.180: 3.3 % low in blue, 0.0003
  // absolute, what the colour matrix leaves of the red in blue), held to 4 %.
  for (const char* name : {"solid-blue", "red-metallic"}) {
    SCOPED_TRACE(name);
    using colour_accuracy::relative_error;
    const auto [paint, pf] = colour_accuracy::measure_and_fit(out, name);
    ASSERT_TRUE(pf.contains("lobes"));
    EXPECT_EQ(pf["input"]["colour_space"], "linear sRGB (D65)");
    for (int c = 0; c < 3; ++c) {
      const bool dark_next_to_red = paint["kd"][c].get<double>() < 0.2 * paint["kd"][0].get<double>();
      EXPECT_LT(relative_error(pf["kd"][c], paint["kd"][c]), dark_next_to_red ? 0.04 : 0.03) << "kd " << c;
      EXPECT_LT(relative_error(pf["lobes"][0]["ks"][c], paint["lobes"][0]["ks"][c]), 0.03) << "lobe 1 ks " << c;
      EXPECT_LT(relative_error(pf["lobes"][1]["ks"][c], paint["lobes"][1]["ks"][c]), 0.08) << "clear coat ks " << c;
    }
    for (int l = 0; l < 2; ++l) {
      EXPECT_LT(relative_error(pf["lobes"][l]["m"], paint["lobes"][l]["m"]), 0.02) << "lobe " << l + 1 << " m";
      EXPECT_LT(relative_error(pf["lobes"][l]["r"], paint["lobes"][l]["r"]), 0.05) << "lobe " << l + 1 << " r";
    }
  }
  // A green pearlescent (paints/green-pearlescent.toml: the layered model, colour travel from
  // green to blue-green), judged as a paint lab judges it, by CIELAB at the five angles: the
  // measurement reads the paint's own values (dE00 0.06-0.5 in this run), and a 3-lobe
  // Cook-Torrance fit, which cannot follow the hue travel of the interference flakes, misses
  // them by up to dE00 2-3 near the gloss (45as15, 45as25) and stays within 1 from 45as45 on.
  {
    SCOPED_TRACE("green-pearlescent");
    const auto [paint, pf] = colour_accuracy::measure_and_fit(out, "green-pearlescent", 3);
    ASSERT_TRUE(pf.contains("lobes"));
    const auto c = colour_accuracy::five_angle_against_truth(out, "green-pearlescent");
    ASSERT_EQ(c.names.size(), 5u);
    for (std::size_t i = 0; i < c.names.size(); ++i) {
      EXPECT_LT(c.measured_de00[i], 1.0) << c.names[i];
      EXPECT_LT(c.fit_de00[i], i < 2 ? 4.0 : 1.5) << c.names[i];
    }
  }
  const std::string journal = read_file(out / "session/journal.jsonl");
  const Json journal_line = Json::parse(journal.substr(0, journal.find('\n')));
  EXPECT_EQ(journal_line["filters"].size(), journal_line["exposures_s"].size());
}

// Issue 13: a fit that stops at its iteration limit does not lose the run (here on the
// monochrome camera, the demo's other camera kind). The demo goes on
// with fit.json ("converged": false), exports, renders, says so in its summary, exits 1.
TEST(DemoCli, AFitThatDoesNotConvergeIsExportedAndSummarised) {
  test::TempDir dir;
  const fs::path out = dir / "demo";
  auto r = test::run_paintlab("demo --quick --camera mono --max-iterations 1 --paint " +
                              (test::source_dir() / "paints/pearlescent.toml").string() + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("did not converge"));
  EXPECT_THAT(r.out, HasSubstr("fit: did NOT converge"));
  EXPECT_THAT(r.out, HasSubstr("the fit did NOT converge (exit 1)"));
  ASSERT_TRUE(fs::exists(out / "summary.json"));
  const Json s = read_json_file(out / "summary.json");
  EXPECT_FALSE(s["fit_converged"].get<bool>());
  EXPECT_THAT(s["fit_termination"].get<std::string>(), HasSubstr("NO_CONVERGENCE"));
  EXPECT_FALSE(s["fit"]["summary"]["converged"].get<bool>());
  // The monochrome camera: the truth it can measure is the paint's kd and ks weighted by its
  // channel weights, and the values are camera RGB.
  EXPECT_EQ(s["camera"], "Mono16");
  EXPECT_FALSE(s.contains("colour"));  // no CIELAB from a monochrome camera
  ASSERT_TRUE(s.contains("truth_seen_by_camera"));
  EXPECT_EQ(s["fit"]["input"]["colour_space"], "linear camera RGB");
  for (const char* f : {"axf", "merl", "fit", "preview", "compare"})
    EXPECT_TRUE(fs::exists(s["files"][f].get<std::string>())) << f;
  EXPECT_EQ(test::run_paintlab("axf validate " + s["files"]["axf"].get<std::string>()).exit_code, 0);
}

TEST(DemoCli, RefusesAFolderThatIsNotADemosAndBadPaints) {
  test::TempDir dir;
  test::write_text(dir / "notes.txt", "mine");
  auto r = test::run_paintlab("demo --quick --out " + dir.path().string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("not empty"));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  auto p = test::run_paintlab("demo --quick --out " + (dir / "x").string() + " --paint " + (dir / "missing.toml").string());
  EXPECT_EQ(p.exit_code, 2) << p.err;
  EXPECT_THAT(p.err, HasSubstr("missing.toml"));
}
