// paintlab demo --out DIR [--paint PAINT.toml] [--quick] [--lobes N]
//
// The simulated rig end to end, as a technician would run it: the demo writes DIR/rig.toml
// (the built-in simulated rig) and then runs the same `paintlab` commands a technician
// types, each as its own process, printing each command before it runs:
//   calibrate all --capture, check --capture, measure, fit, export (AxF-like + MERL),
//   library add, render (preview and measured-vs-model comparison).
// Then it compares what came out with the simulator's truth (the paint, the camera, the
// sphere, the LED, the response curve), prints a summary table and writes DIR/summary.json
// in the shape of DESIGN.md's contract.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>

#include "cli.h"
#include "paintlab/fitting/compare.h"
#include "paintlab/fitting/multiangle.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/score.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/core/process.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/sim/builtin.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/sensor.h"
#include "paintlab/sim/world.h"
#include "rig_devices.h"

namespace paintlab::app {
namespace {

// The commands' descriptions (their --help).
constexpr const char* kDemoHelp =
    "The simulated rig end to end: calibrate, check, measure, fit, export, library, preview; prints a summary "
    "(truth vs fit, calibration errors, timings) and writes DIR/summary.json";

namespace fs = std::filesystem;

constexpr const char* kMarker = ".paintlab-demo";

struct DemoArgs {
  std::string out;
  std::string paint;
  bool quick = false;
  int lobes = 0;
  bool keep_going = false;
  int max_iterations = 100;  // of the fit's final solve (paintlab fit --max-iterations)
  std::string camera = "bayer";
};

// Runs `paintlab ARGS...` as a child (output goes to the terminal), returns its exit code
// and adds its wall time to `seconds`.
int run_step(const std::vector<std::string>& args, double& seconds) {
  std::string shown = "paintlab";
  for (const auto& a : args) shown += " " + (a.find(' ') == std::string::npos ? a : "'" + a + "'");
  say("");
  say("$ " + shown);
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = run_process(self_executable(), args);
  seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rc;
}

// The simulator's truth as the plain numbers calib::score_calibration takes.
calib::CalibrationTruth calibration_truth(const RigConfig& rig, const sim::SimConfig& truth) {
  calib::CalibrationTruth t;
  t.K = truth.camera.K();
  const sim::SimWorld world(truth);
  t.sphere_centre_cam_m = world.sphere_centre_cam();
  for (double a : rig.plan.angles_deg()) {
    t.angles_deg.push_back(a);
    t.led_cam_m.push_back(world.led_position_cam(a));
  }
  const sim::ResponseCurve r(truth.sensor.response_poly);
  constexpr int kSamples = 4000;  // linear interpolation between them: below 1e-6 of the value
  for (int i = 0; i <= kSamples; ++i) {
    const double x = static_cast<double>(i) / kSamples;
    t.inverse_response.emplace_back(x, r.inverse(x));
  }
  t.adc_bits = truth.sensor.adc_bits;
  t.black_level_dn = truth.sensor.black_level_dn;
  t.adc_max_dn = truth.sensor.adc_max_dn();
  return t;
}

void print_summary(const Json& s) {
  say("");
  say(fmt::format("== paintlab demo: {} ==", s["paint"].get<std::string>()));
  const Json& truth = s.contains("truth_seen_by_camera") ? s["truth_seen_by_camera"] : s["truth"];
  const Json& fit = s["fit"];
  if (s.contains("truth_seen_by_camera"))
    say("(a monochrome camera: the truth column is the paint as the camera sees it, kd and ks weighted by its "
        "channel weights; the paint's own RGB is under \"truth\" in summary.json)");
  else
    say(fmt::format("(a colour camera, {}: R, G, B in linear sRGB (D65), the paint's own colour)",
                    s.value("camera", std::string())));
  say(fit::compare_table(truth, fit, fit.value("stddev", Json::object())));
  if (fit.contains("residual"))
    say(fmt::format("residual: log-RMS {:.4f} over {} bins", fit["residual"].value("log_rms", 0.0),
                    fit["residual"].value("bins_used", 0)));
  if (!s.value("fit_converged", true))
    say(fmt::format("fit: did NOT converge ({}); the parameters above are the solver's last",
                    s.value("fit_termination", std::string("no termination recorded"))));
  else if (s.contains("fit_converged"))
    say("fit: converged");
  if (s.contains("colour")) say(fit::colour_against_truth_table(s["colour"]));
  say("calibration against the simulator's truth:");
  for (const auto& [k, v] : s["calibration"].items()) say(fmt::format("  {:<26} {:.5g}", k, v.get<double>()));
  say("timings (s):");
  for (const auto& [k, v] : s["timings_s"].items()) say(fmt::format("  {:<26} {:.1f}", k, v.get<double>()));
  say("files:");
  for (const auto& [k, v] : s["files"].items()) say(fmt::format("  {:<26} {}", k, v.get<std::string>()));
}

int run_demo(const DemoArgs& a) {
  if (a.out.empty()) throw UsageError("demo: --out DIR is required");
  if (a.lobes < 0 || a.lobes > 3) throw UsageError("demo --lobes: 1..3 (0: as many as the paint has, at most 3)");
  if (a.max_iterations < 1) throw UsageError(fmt::format("demo --max-iterations {}: must be >= 1", a.max_iterations));
  const fs::path dir = fs::absolute(a.out);
  {
    OutputSpec out("--out", a.out);
    out.folder = true;
    out.create_parents = true;
    fit::OutputGuard().input("--paint", a.paint).output(out).check();
  }
  const sim::SimulatedPaint paint = sim::simulated_paint(a.paint, "demo --paint");
  const std::string name = paint.spec.name;
  if (fs::exists(dir) && !fs::is_directory(dir)) throw UsageError(fmt::format("demo --out {}: not a folder", dir.string()));
  if (fs::exists(dir) && !fs::is_empty(dir) && !fs::exists(dir / kMarker))
    throw UsageError(fmt::format("demo --out {}: the folder is not empty and holds no earlier demo; give a new folder",
                                 dir.string()));
  fs::create_directories(dir);
  // An earlier demo's results are replaced as a whole (never mixed with this run's).
  for (const char* old : {"calib", "session", "library", "summary.json", "fit.json", "report.html"})
    fs::remove_all(dir / old);
  write_file_atomic(dir / kMarker, "written by paintlab demo; a later demo may replace this folder's contents\n");

  const fs::path rig_file = dir / "rig.toml";
  const fs::path paint_file = dir / (name + ".toml");
  const sim::DemoCamera camera = sim::demo_camera_from_string(a.camera, "demo --camera");
  write_file_atomic(rig_file, sim::demo_rig_toml(a.quick, camera));
  write_file_atomic(paint_file, paint.toml_text);
  const RigConfig rig = load_rig(rig_file);
  const sim::SimConfig truth = sim::SimConfig::from_rig(rig);
  say(fmt::format("paintlab demo{}: the simulated rig ({}x{} px, {} light positions, {} exposures) measures {}",
                  a.quick ? " --quick" : "", rig.geometry.image_width_px, rig.geometry.image_height_px,
                  rig.plan.angles_deg().size(), rig.plan.exposures_s.size(), name));
  say("rig: " + rig_file.string() + ", results in " + dir.string());

  pass_signals_to_children();  // Ctrl-C reaches the child (same process group), which stops safely
  const auto t_start = std::chrono::steady_clock::now();
  double t_cal = 0, t_check = 0, t_measure = 0, t_fit = 0, t_export = 0;
  const std::string R = rig_file.string();
  const fs::path session = dir / "session";
  const fs::path fit_file = dir / "fit.json";
  const fs::path axf = dir / (name + ".axf.h5");
  const fs::path merl = dir / (name + ".binary");
  const fs::path preview = dir / "preview.png";
  const fs::path compare = dir / "compare.png";
  const fs::path library = dir / "library";
  const fs::path report = dir / "report.html";
  const fs::path flakes = dir / "flakes.json";
  const int lobes = a.lobes > 0 ? a.lobes
                                : std::clamp(static_cast<int>(paint.spec.cook_torrance()
                                                                  ? paint.spec.cook_torrance()->lobes.size()
                                                                  : 2),
                                             1, 3);
  auto step = [&](const std::vector<std::string>& args, double& t, const char* what) {
    const int rc = run_step(args, t);
    if (rc != 0) {
      throw JobError(fmt::format("demo: {} failed (exit {}); the files so far are in {}", what, rc, dir.string()));
    }
  };
  step({"calibrate", "all", "--rig", R, "--capture"}, t_cal, "calibration");
  {
    const int rc = run_step({"check", "--rig", R, "--capture"}, t_check);
    if (rc != 0 && !a.keep_going) {
      say("demo: the rig check failed (see the table above); --keep-going measures anyway");
      return kExitFailed;
    }
  }
  step({"measure", "--rig", R, "--sample", name, "--out", session.string(), "--sim-paint", paint_file.string(),
        "--notes", "paintlab demo"},
       t_measure, "the measurement");
  // A fit that stops before converging exits 1 but writes fit.json ("converged": false; an
  // earlier demo's fit.json is gone): the demo goes on with it, says so in its summary and
  // exits 1 at the end.
  const int fit_rc = run_step({"fit", session.string(), "--model", "cook-torrance", "--lobes", std::to_string(lobes),
                               "--name", name, "--max-iterations", std::to_string(a.max_iterations), "--out",
                               fit_file.string()},
                              t_fit);
  if (fit_rc != 0 && !(fit_rc == kExitFailed && fs::exists(fit_file)))
    throw JobError(fmt::format("demo: the fit failed (exit {}); the files so far are in {}", fit_rc, dir.string()));
  if (fit_rc != 0) say("demo: the fit did not converge; going on with its last parameters (fit.json says so)");
  // The flakes: their statistics against the fit, into the AxF-like file with it (a paint
  // without flakes gets an empty model and no flake groups).
  step({"flakes", session.string(), "--fit", fit_file.string(), "--out", flakes.string()}, t_export,
       "the flake statistics");
  step({"export", fit_file.string(), "--axf", axf.string(), "--flakes", flakes.string()}, t_export,
       "the AxF-like export");
  step({"export", session.string(), "--merl", merl.string()}, t_export, "the MERL export");
  step({"axf", "validate", axf.string()}, t_export, "validating the AxF-like file");
  step({"library", "add", "--dir", library.string(), axf.string(), "--replace"}, t_export, "adding to the library");
  step({"render", axf.string(), "--out", preview.string()}, t_export, "the preview");
  step({"render", axf.string(), "--out", compare.string(), "--compare", session.string()}, t_export,
       "the measured-vs-model comparison");
  // A colour camera's measurement as a paint lab reads it: CIELAB at the five angles, of the
  // paint, of the measured samples nearest each and of the fit (a monochrome one has none).
  Json colour;
  if (camera != sim::DemoCamera::Mono) {
    fit::MeasuredInputOptions mo;
    mo.fit_file = fit_file;
    colour = fit::colour_against_truth(
        paint.spec, fit::measured_paint_colour(session, fit::geometry_set(fit::kDefaultGeometrySet), mo));
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  Json fit = read_json_file(fit_file);
  Json summary;
  summary["paint"] = name;
  summary["truth"] = brdf::to_json(paint.spec);
  summary["camera"] = std::string(dev::to_string(dev::camera_config(rig.camera, rig.geometry).pixel_format)) +
                      (rig.filter_wheel ? " behind a filter wheel" : "");
  const auto& w = truth.camera.mono_weights;  // a monochrome camera measures the paint through them
  if (camera == sim::DemoCamera::Mono)
    summary["truth_seen_by_camera"] = brdf::to_json(brdf::seen_in_mono(paint.spec, brdf::Rgb(w[0], w[1], w[2])));
  summary["fit"] = fit;
  const Json& fit_summary = fit.contains("summary") && fit["summary"].is_object() ? fit["summary"] : Json::object();
  const bool fit_converged = fit_summary.value("converged", true);
  summary["fit_converged"] = fit_converged;
  summary["fit_termination"] = fit_summary.value("termination", std::string());
  summary["calibration"] =
      calib::score_calibration(calib::RigCalibration::load(rig), calibration_truth(rig, truth)).to_json();
  summary["timings_s"] = {{"calibrate", t_cal + t_check}, {"measure", t_measure}, {"fit", t_fit},
                          {"export", t_export},          {"total", total}};
  summary["files"] = {{"axf", axf.string()},         {"merl", merl.string()},       {"fit", fit_file.string()},
                      {"preview", preview.string()}, {"compare", compare.string()}, {"session", session.string()},
                      {"library", library.string()}, {"rig", R},                   {"report", report.string()},
                      {"flakes", flakes.string()}};
  {
    // The measured sparkle (docs/sparkle.md): the whole sweep's figures and the instrument-style ones.
    const Json fl = read_json_file(flakes);
    Json sp = {{"area", fl.at("area")},
               {"glints", fl.at("glints")},
               {"lifetime_deg", fl.at("lifetime_deg")},
               {"empty", fl.at("empty")},
               {"instrument", fl.at("instrument")}};
    if (paint.spec.flakes) sp["truth_lifetime_deg"] = paint.spec.flakes->lifetime_deg;
    summary["sparkle"] = sp;
  }
  summary["quick"] = a.quick;
  if (!colour.is_null()) summary["colour"] = colour;
  write_json_file(dir / "summary.json", summary);
  // The report reads what the demo wrote, summary.json included; its time is added after.
  double t_report = 0;
  step({"report", dir.string(), "--out", report.string()}, t_report, "the report");
  summary["timings_s"]["report"] = t_report;
  summary["timings_s"]["total"] = total + t_report;
  write_json_file(dir / "summary.json", summary);
  print_summary(summary);
  if (!fit_converged) {
    say(fmt::format("demo finished in {:.1f} s, but the fit did NOT converge (exit 1): {}", total + t_report,
                    (dir / "summary.json").string()));
    return kExitFailed;
  }
  say(fmt::format("demo finished in {:.1f} s: {} (open {} in a browser)", total + t_report,
                  (dir / "summary.json").string(), report.string()));
  return kExitOk;
}

}  // namespace

void register_demo_commands(CLI::App& app) {
  auto [d, a] = add_command<DemoArgs>(&app, "demo", kDemoHelp, run_demo);
  d->add_option("--out", a->out, "Folder for everything the demo writes (new, or an earlier demo's)")->required();
  d->add_option("--paint", a->paint, "Paint file to measure (default: the built-in silver-metallic)");
  d->add_flag("--quick", a->quick, "Half resolution, light every 10 deg, 8 exposures (under 2 minutes)");
  sets_fields(d->add_option("--lobes", a->lobes, "Cook-Torrance lobes to fit (default: the paint's, at most 3)"),
              {"CtFitOptions::lobes"});
  d->add_flag("--keep-going", a->keep_going, "Measure even when the rig check fails");
  d->add_option("--camera", a->camera,
                "bayer: a BayerRG16 colour camera; wheel: Mono16 behind a filter wheel (both R, G, B in linear sRGB); "
                "mono: Mono16")
      ->capture_default_str();
  sets_fields(d->add_option("--max-iterations", a->max_iterations,
                            "Iterations of the fit's final solve (paintlab fit --max-iterations); a fit that stops "
                            "there is exported and summarised all the same, and the demo exits 1"),
              {"CtFitOptions::max_iterations"})
      ->capture_default_str();
}

}  // namespace paintlab::app
