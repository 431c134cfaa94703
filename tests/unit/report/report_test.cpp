// paintlab report: what each kind of input puts on the page, what a damaged or foreign input
// does (exit 2, nothing written), and that the page loads nothing from anywhere. The browser
// test of a whole demo's report is in tests/e2e/demo (report_browser.h).
#include <gmock/gmock.h>
#include <gtest/gtest.h>


#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/report/plot.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/report/report.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

namespace {

// A fit.json as `paintlab fit` writes it (two lobes, curves at two theta_d).
Json fit_json(bool converged) {
  Json curve5 = {{"theta_d_deg", 5.0},
                 {"theta_h_deg", {0.5, 2.0, 8.0, 20.0}},
                 {"measured", {12.0, 3.0, 0.4, 0.05}},
                 {"model", {11.5, 3.1, 0.41, 0.049}},
                 {"points", {3, 5, 9, 20}}};
  Json curve30 = curve5;
  curve30["theta_d_deg"] = 30.0;
  return {{"name", "test-silver"},
          {"model", "cook-torrance"},
          {"kd", {0.031, 0.032, 0.035}},
          {"lobes",
           {{{"ks", {0.058, 0.060, 0.064}}, {"m", 0.3802}, {"r", 0.8757}},
            {{"ks", {0.15, 0.153, 0.164}}, {"m", 0.01551}, {"r", 0.04}}}},
          {"stddev",
           {{"kd", {3e-5, 2e-5, 3e-5}},
            {"lobes", {{{"ks", {7e-4, 7e-4, 8e-4}}, {"m", 7e-5}, {"r", 0.008}}, {{"ks", {0.016, 0.014, 0.016}}, {"m", 1e-4}, {"r", 0.003}}}}}},
          {"residual",
           {{"log_rms", 0.2613},
            {"bins_used", 179921},
            {"residuals", 179921},
            {"noise_floor_log_rms", 0.0211},
            {"noise_source", "sample-noise"},
            {"regions",
             {{"diffuse", {{"bins", 128300}, {"residuals", 128300}, {"log_rms", 0.02666}, {"noise_floor", 0.02437}}},
              {"peak", {{"bins", 913}, {"residuals", 913}, {"log_rms", 0.7044}, {"noise_floor", 0.0088}}}}},
            {"curves", {curve5, curve30}}}},
          {"summary",
           {{"converged", converged},
            {"termination", converged ? "CONVERGENCE: Function tolerance reached." : "NO_CONVERGENCE: maximum iterations"},
            {"iterations", 29},
            {"time_s", 8.3},
            {"initial_cost", 190515.0},
            {"final_cost", 190446.0},
            {"chi2_per_dof", 2.117}}},
          {"input", {{"kind", "table"}, {"path", "/nowhere/table.binary"}, {"colour_space", "linear sRGB (D65)"}}}};
}

// A calibration folder with the intrinsics and a check that failed one item; the other
// stages missing.
void write_calibration(const fs::path& dir) {
  fs::create_directories(dir);
  Json views = Json::array();
  // Each view's corners with residuals of 0.03 px and one of 0.04 px (so RMS over the used
  // views' 5 x 4 corners: sqrt((5 x 3 x 0.03^2 + 5 x 0.04^2) / 20)).
  for (int i = 0; i < 6; ++i)
    views.push_back({{"name", "view0" + std::to_string(i)}, {"rms_px", 0.01 + 0.002 * i}, {"max_px", 0.03 + 0.004 * i},
                     {"used", i != 5},
                     {"corners_px", {{100, 100}, {200, 100}, {100, 200}, {200, 200}}},
                     {"residuals_px", {{0.03, 0.0}, {0.0, -0.03}, {-0.03, 0.0}, {0.0, 0.04}}}});
  write_json_file(dir / "camera.json", {{"K", {{3889.65, 0.0, 342.9}, {0.0, 3888.68, 256.18}, {0.0, 0.0, 1.0}}},
                                        {"dist", {-0.2066, 0.4357, 0.00068, -0.00023, 0.0}},
                                        {"std", {{"fx", 2.228}, {"fy", 2.123}, {"cx", 4.25}, {"cy", 2.99}, {"dist", {0.01, 0.2, 1e-4, 1e-4, 0.0}}}},
                                        {"rms_px", 0.009507},
                                        {"worst_px", 0.0304},
                                        {"views_used", 5},
                                        {"views_dropped", 1},
                                        {"image_size", {680, 512}},
                                        {"k3", {{"fixed", true}, {"note", "k3 fixed at 0"}}},
                                        {"views", views}});
  write_json_file(dir / "check.json",
                  {{"passed", false},
                   {"failures", 1},
                   {"date", "2026-12-06T01:42:25Z"},
                   {"rig", "test-rig"},
                   {"checks",
                    {{{"id", "intrinsics.file"}, {"what", "camera.json present"}, {"limit", "required"}, {"pass", true},
                      {"tolerance", nullptr}, {"value", nullptr}, {"action", "run calibrate intrinsics"}},
                     {{"id", "sphere.focus"}, {"what", "sphere edge sharpness"}, {"limit", "at_most"}, {"pass", false},
                      {"tolerance", 1.5}, {"value", 2.75}, {"unit", "px"}, {"action", "refocus the camera on the sphere"}}}}});
}

std::string report_of(const fs::path& input) { return report::make_report(report::classify_input(input)).html; }

// Every src= and href= of the page points inside it (data: URIs, #anchors). (Scanned by hand:
// std::regex recurses per character and overflows the stack on a data: URI of 300 kB.)
void expect_self_contained(const std::string& html) {
  int refs = 0;
  for (const std::string attr : {" src=\"", " href=\""}) {
    for (auto at = html.find(attr); at != std::string::npos; at = html.find(attr, at + 1), ++refs) {
      const std::string target = html.substr(at + attr.size(), 8);
      EXPECT_TRUE(target.rfind("data:", 0) == 0 || target.rfind("#", 0) == 0) << target;
    }
  }
  EXPECT_GT(refs, 0);
  EXPECT_THAT(html, Not(HasSubstr("<link")));
  EXPECT_THAT(html, Not(HasSubstr("<script")));
  EXPECT_THAT(html, Not(HasSubstr("http://")));
  EXPECT_THAT(html, Not(HasSubstr("https://")));
}

// The text of the element with this id (tags inside stripped).
std::string element_text(const std::string& html, const std::string& id) {
  const auto at = html.find("id=\"" + id + "\"");
  if (at == std::string::npos) return "(no element " + id + ")";
  const auto start = html.find('>', at) + 1;
  const auto end = html.find("</", start);
  std::string text;
  bool in_tag = false;
  for (char c : html.substr(start, end - start)) {
    if (c == '<') in_tag = true;
    if (!in_tag) text += c;
    if (c == '>') in_tag = false;
  }
  return text;
}

}  // namespace

TEST(ReportPlot, GnuplotDrawsAnSvgWithTheTitleAndRefusesAPlotWithoutPoints) {
  report::Plot p;
  p.title = "Response \"curve\"";
  p.xlabel = "DN";
  p.log_y = true;
  report::Series g;
  g.title = "g(u)";
  g.x = {1, 2, 3, 4};
  g.y = {1, 10, 100, -1};
  g.style = "linespoints";
  p.series = {g};
  const std::string svg = report::plot_svg(p);
  EXPECT_THAT(svg, HasSubstr("<svg"));
  EXPECT_THAT(svg, HasSubstr("Response"));
  // The non-positive value is left out of a log plot instead of breaking it.
  EXPECT_THAT(report::gnuplot_script(p), Not(HasSubstr(" -1\n")));
  report::Plot empty;
  empty.title = "nothing";
  report::Series nan_only;
  nan_only.x = {1.0};
  nan_only.y = {std::nan("")};
  empty.series = {nan_only};
  EXPECT_THAT(test::error_message<DataError>([&] { report::plot_svg(empty); }), HasSubstr("no finite point"));
}

TEST(Report, AFitShowsItsParametersResidualsAndCurvesOnAPageThatLoadsNothing) {
  test::TempDir dir;
  write_json_file(dir / "fit.json", fit_json(true));
  const std::string html = report_of(dir / "fit.json");
  expect_self_contained(html);
  EXPECT_THAT(element_text(html, "fit-log-rms"), HasSubstr("0.2613"));
  EXPECT_THAT(element_text(html, "fit-log-rms-peak"), HasSubstr("0.7044"));
  EXPECT_THAT(element_text(html, "fit-lobe1-m"), HasSubstr("0.3802 ± 7e-05"));
  EXPECT_THAT(element_text(html, "fit-kd"), HasSubstr("0.031 ± 3e-05"));
  EXPECT_THAT(element_text(html, "fit-converged"), HasSubstr("Converged"));
  EXPECT_THAT(html, HasSubstr("data:image/svg+xml;base64,"));  // the curves' plot
  // Its colour at the five geometries (the fit is linear sRGB).
  EXPECT_THAT(html, HasSubstr("id=\"colour-L-45as45\""));
  EXPECT_THAT(element_text(html, "status-verdict"), HasSubstr("nothing missing"));
}

TEST(Report, FlakesBesideAFitGiveASparkleSectionWithTheInstrumentNumbers) {
  test::TempDir dir;
  write_json_file(dir / "fit.json", fit_json(true));
  fit::FlakeStats f;
  f.colour_space = colour::kLinearSrgb;
  f.images = 10;
  f.runs = 12;
  f.lifetime_deg = 5.25;
  f.step_deg = 0.5;
  fit::FlakeSlice a;
  a.theta_f = 0;
  a.theta_i = 2;
  a.pixels = 2000;
  a.glints = 300;
  a.intensity_mean = 3.5;
  a.intensity_quantiles = {1, 2, 3, 4, 5};
  a.clusters = {{{100, -4, 2}, {110, 0, 6}, {105, -2, 4}, 0.6, 180}, {{120, 5, -9}, {130, 9, -3}, {125, 7, -6}, 0.4, 120}};
  a.inverse_cdf = {0, 0, 0, 1, 1};
  f.slices = {a};
  f.pixels = 2000;
  f.glints = 300;
  f.instrument = {{15, 400, 60, 15.0, 2.5}, {45, 300, 3, 1.0, 1.2}, {75, 0, 0, 0, 0}};
  write_json_file(dir / "flakes.json", fit::flakes_to_json(f));
  const std::string html = report_of(dir / "fit.json");
  expect_self_contained(html);
  EXPECT_THAT(element_text(html, "sparkle-area"), HasSubstr("15 %"));
  EXPECT_THAT(element_text(html, "sparkle-lifetime"), HasSubstr("5.25"));
  EXPECT_THAT(element_text(html, "sparkle-area-15"), HasSubstr("15 %"));
  EXPECT_THAT(html, HasSubstr("not measured"));  // 75 deg: no observation, not 0
  EXPECT_THAT(html, HasSubstr("class=\"swatch\""));
  // A damaged flakes.json is named, the rest of the page stands.
  write_file_atomic(dir / "flakes.json", "{\"format\": \"paintlab-flakes\", ");
  const report::Report r = report::make_report(report::classify_input(dir / "fit.json"));
  EXPECT_THAT(r.html, HasSubstr("flakes.json"));
  EXPECT_FALSE(r.missing.empty());
}

TEST(Report, AFitOfSeveralSessionsNamesEachOne) {
  test::TempDir dir;
  Json fit = fit_json(true);
  fit["input"] = {{"kind", "sessions"},
                  {"path", "/lab/silver-a"},
                  {"colour_space", "linear sRGB (D65)"},
                  {"sessions", {{{"path", "/lab/silver-a"}}, {{"path", "/lab/silver-b"}}}}};
  write_json_file(dir / "fit.json", fit);
  const std::string html = report_of(dir / "fit.json");
  EXPECT_THAT(html, HasSubstr("from sessions 2 together: <code>/lab/silver-a</code>, <code>/lab/silver-b</code>"));
}

TEST(Report, AFitThatDidNotConvergeIsShownAsFailing) {
  test::TempDir dir;
  write_json_file(dir / "fit.json", fit_json(false));
  const report::Report r = report::make_report(report::classify_input(dir / "fit.json"));
  ASSERT_EQ(r.failing.size(), 1u);
  EXPECT_THAT(r.failing[0], HasSubstr("maximum iterations"));
  EXPECT_THAT(element_text(r.html, "fit-converged"), HasSubstr("Did NOT converge"));
  EXPECT_THAT(element_text(r.html, "status-verdict"), HasSubstr("Failing"));
}

TEST(Report, ACalibrationFolderWithAFailedCheckListsTheFailureFirstAndWhatIsMissing) {
  test::TempDir dir;
  write_calibration(dir / "calib");
  const report::Report r = report::make_report(report::classify_input(dir / "calib"));
  EXPECT_EQ(report::classify_input(dir / "calib").kind, report::InputKind::Calibration);
  expect_self_contained(r.html);
  EXPECT_THAT(element_text(r.html, "camera-rms-px"), HasSubstr("0.009507"));
  EXPECT_THAT(element_text(r.html, "camera-fx"), HasSubstr("3889.65 ± 2.2"));
  EXPECT_THAT(element_text(r.html, "check-verdict"), HasSubstr("FAILED: 1 of 2"));
  EXPECT_THAT(element_text(r.html, "check-sphere.focus"), HasSubstr("2.75 px"));
  // The failing check comes before the passing one, with what to do about it.
  EXPECT_LT(r.html.find("check-sphere.focus"), r.html.find("check-intrinsics.file"));
  EXPECT_THAT(r.html, HasSubstr("refocus the camera on the sphere"));
  ASSERT_EQ(r.failing.size(), 1u);
  EXPECT_THAT(r.failing[0], HasSubstr("sphere.focus"));
  // Seven stages have no file: each named with the command that makes it.
  EXPECT_EQ(r.missing.size(), 7u);
  EXPECT_THAT(r.html, HasSubstr("missing: run <code>paintlab calibrate light</code>"));
  EXPECT_THAT(r.html, HasSubstr("Dropped: view05"));
  // The corner residuals of the views in the fit (the dropped view's are drawn, not counted).
  EXPECT_NEAR(std::stod(element_text(r.html, "corner-rms-px")), std::sqrt((15 * 0.0009 + 5 * 0.0016) / 20.0), 1e-4);
}

TEST(Report, ACalibrationFolderBesideItsRigFileComparesTheArmWithTheNominalOne) {
  test::TempDir dir;
  write_calibration(dir / "calib");
  write_file_atomic(dir / "rig.toml", "calibration = \"calib\"\nname = \"r1\"\n" + test::kSimDevicesToml + R"([geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.6
arm_zero_deg = 0.1
camera_distance_m = 1.2
[plan]
angle_start_deg = 0
angle_stop_deg = 180
angle_step_deg = 1
exposures_ms = [0.25, 1, 4]
)");
  write_json_file(dir / "calib" / "light.json",
                  {{"arm_radius_m", 0.6021}, {"arm_height_m", 0.0027}, {"zero_deg", 0.18}, {"rms_deg", 0.003},
                   {"max_deg", 0.006}, {"std", {{"arm_radius_m", 0.0009}, {"arm_height_m", 1e-5}, {"zero_deg", 0.001}}},
                   {"highlights", {{{"table_angle_deg", -10.0}, {"used", true}, {"azimuth_error_deg", 0.002}},
                                   {{"table_angle_deg", 0.0}, {"used", true}, {"azimuth_error_deg", -0.001}},
                                   {{"table_angle_deg", 10.0}, {"used", false}, {"reason", "too close to the silhouette"}}}}});
  const report::ReportInput in = report::classify_input(dir / "calib");
  EXPECT_EQ(in.rig, dir / "rig.toml");
  const std::string html = report::make_report(in).html;
  EXPECT_NEAR(std::stod(element_text(html, "arm-radius-diff-mm")), 2.1, 1e-6);
  EXPECT_NEAR(std::stod(element_text(html, "arm-height-diff-mm")), 2.7, 1e-6);
  EXPECT_NEAR(std::stod(element_text(html, "arm-zero-diff-deg")), 0.08, 1e-6);
  EXPECT_THAT(html, HasSubstr("too close to the silhouette"));
  // Another rig file given with --rig (ReportOptions::rig) is the one compared with.
  write_file_atomic(dir / "other.toml", "name = \"r2\"\n" + test::kSimDevicesToml + R"([geometry]
sphere_radius_m = 0.04
arm_radius_m = 0.5
camera_distance_m = 1.2
[plan]
angle_start_deg = 0
angle_stop_deg = 180
angle_step_deg = 1
exposures_ms = [0.25, 1, 4]
)");
  report::ReportOptions o;
  o.rig = dir / "other.toml";
  EXPECT_NEAR(std::stod(element_text(report::make_report(in, o).html, "arm-radius-diff-mm")), 102.1, 1e-6);
}

TEST(Report, AnIncompleteSessionSaysHowManyPositionsAreMissingAndHowToResume) {
  test::TempDir dir;
  const fs::path s = dir / "session";
  fs::create_directories(s);
  write_json_file(s / "session.json", {{"format_version", 2},
                                       {"sample", "test-silver"},
                                       {"created_utc", "2026-12-06T01:42:25Z"},
                                       {"plan", {{"angles_deg", {0.0, 10.0, 20.0, 30.0, 40.0}}, {"exposures_s", {0.001, 0.01}}}}});
  std::string journal;
  // Two positions in a first run, one after a resume (the rig clock starts again).
  const double starts[] = {0.0, 1.2, 0.0};
  for (int i = 0; i < 3; ++i)
    journal += Json{{"index", i}, {"angle_deg", 10.0 * i}, {"clock_start_s", starts[i]}, {"clock_end_s", starts[i] + 1.1},
                    {"exposures_s", {0.001, 0.01}}, {"file", "hdr/pos.exr"}, {"sha256", "0"}}
                   .dump() +
               "\n";
  write_file_atomic(s / "journal.jsonl", journal);
  // The runs as `paintlab measure` records them: one stopped by Ctrl-C, one after a retry.
  write_file_atomic(s / "runs.jsonl",
                    Json{{"utc_end", "2026-12-06T01:43:00Z"}, {"positions", 5}, {"finished_before", 0}, {"measured", 2},
                         {"complete", false}, {"interrupted", true}, {"stop_reason", ""}, {"sweep_s", 2.3},
                         {"physical_min_s", 2.2}, {"frames", 4}, {"retries", 0}}
                            .dump() +
                        "\n" +
                        Json{{"utc_end", "2026-12-06T01:44:00Z"}, {"positions", 5}, {"finished_before", 2}, {"measured", 1},
                             {"complete", false}, {"device_fault", true}, {"stop_reason", "camera: no frame"},
                             {"sweep_s", 1.25}, {"physical_min_s", 1.0}, {"frames", 2}, {"retries", 3}}
                            .dump() +
                        "\n");
  const report::Report r = report::make_report(report::classify_input(s));
  EXPECT_THAT(element_text(r.html, "session-positions"), HasSubstr("3 of 5 light positions finished; 2 missing"));
  EXPECT_THAT(r.html, HasSubstr("paintlab measure --resume"));
  EXPECT_THAT(r.html, HasSubstr("2 runs"));
  EXPECT_THAT(element_text(r.html, "run2-ratio"), HasSubstr("1.25"));
  EXPECT_THAT(r.html, HasSubstr("device fault: camera: no frame"));
  EXPECT_THAT(r.html, HasSubstr("stopped (Ctrl-C)"));
  ASSERT_FALSE(r.missing.empty());
  EXPECT_THAT(r.missing[0], HasSubstr("2 of 5 light positions missing"));
}

TEST(Report, InputThatIsNoneOfTheFourKindsOrDamagedIsRefusedNaming) {
  test::TempDir dir;
  fs::create_directories(dir / "empty");
  EXPECT_THAT(test::error_message<DataError>([&] { report::classify_input(dir / "empty"); }),
              HasSubstr("none of the four kinds"));
  EXPECT_THAT(test::error_message<DataError>([&] { report::classify_input(dir / "absent"); }), HasSubstr("not found"));
  write_file_atomic(dir / "fit.json", "{\"model\": \"cook-torrance\", \"kd\": [0.1, ");
  EXPECT_THAT(test::error_message<DataError>([&] { report::classify_input(dir / "fit.json"); }), HasSubstr("fit.json"));
  write_json_file(dir / "other.json", {{"hello", 1}});
  EXPECT_THAT(test::error_message<DataError>([&] { report::classify_input(dir / "other.json"); }),
              HasSubstr("not a fit"));
  // A calibration folder whose camera.json is damaged: the report stops (no page with a hole
  // where the figures should be).
  write_calibration(dir / "calib");
  write_file_atomic(dir / "calib" / "camera.json", "{\"K\": [[1, 0");
  EXPECT_THAT(test::error_message<DataError>([&] { report_of(dir / "calib"); }), HasSubstr("camera.json"));
}

TEST(ReportCli, WritesThePageAndRefusesBadInputWithoutWritingAnything) {
  test::TempDir dir;
  write_json_file(dir / "fit.json", fit_json(true));
  auto ok = test::run_paintlab("report " + (dir / "fit.json").string() + " --out " + (dir / "r.html").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("wrote"));
  EXPECT_TRUE(fs::exists(dir / "r.html"));

  fs::create_directories(dir / "empty");
  auto bad = test::run_paintlab("report " + (dir / "empty").string() + " --out " + (dir / "bad.html").string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("none of the four kinds"));
  EXPECT_FALSE(fs::exists(dir / "bad.html"));

  write_file_atomic(dir / "broken.json", "{\"model\": ");
  auto broken = test::run_paintlab("report " + (dir / "broken.json").string() + " --out " + (dir / "b.html").string());
  EXPECT_EQ(broken.exit_code, 2);
  EXPECT_THAT(broken.err, HasSubstr("broken.json"));
  EXPECT_FALSE(fs::exists(dir / "b.html"));

  // Never over its input.
  auto over = test::run_paintlab("report " + (dir / "fit.json").string() + " --out " + (dir / "fit.json").string());
  EXPECT_EQ(over.exit_code, 2);
  EXPECT_THAT(over.err, HasSubstr("--out"));
  EXPECT_EQ(read_json_file(dir / "fit.json").at("name"), "test-silver");
}
