// paintlab measure: the light sweep of one sample (issue "Measurement sessions").
//   paintlab measure --rig R --sample NAME --out DIR [--notes TEXT] [--keep-raw] [--adaptive]
//   paintlab measure --resume DIR
#include <atomic>
#include <csignal>
#include <filesystem>
#include <fmt/format.h>
#include <optional>

#include "cli.h"
#include "measure_support.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/acquisition/adaptive.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/acquisition/measurement.h"
#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/calibration/record.h"
#include <spdlog/spdlog.h>

#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/process.h"
#include "paintlab/core/progress.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/sim/builtin.h"
#include "paintlab/brdf/paint.h"
#include "rig_devices.h"

namespace fs = std::filesystem;

namespace paintlab::app {
namespace {

// The commands' descriptions (their --help).
constexpr const char* kMeasureHelp =
    "Measure a sample: sweep the light, capture exposure brackets, merge them into HDR images.\n"
    "A colour camera (Bayer, or monochrome behind the rig's filter wheel: one bracket per filter)\n"
    "stores R, G, B in linear sRGB after calib/colour.json (docs/colour.md).\n"
    "Writes DIR/session.json, DIR/journal.jsonl and DIR/hdr/pos_XXX.exr. Ctrl-C stops safely\n"
    "(LED off, table stopped); `paintlab measure --resume DIR` continues where it stopped.";

struct MeasureArgs {
  std::string rig;
  std::string sample;
  std::string out;
  std::string resume;
  std::string notes;
  std::string operator_name;
  std::string sim_paint;
  bool keep_raw = false;
  bool adaptive = false;
  bool uncalibrated = false;
  std::string demosaic;
  int max_retries = 3;
};

int run_measure(const MeasureArgs& a) {
  const bool resume = !a.resume.empty();
  if (resume && (!a.out.empty() || !a.sample.empty()))
    throw UsageError("--resume DIR continues a session: do not combine it with --out or --sample");
  if (!resume && (a.rig.empty() || a.sample.empty() || a.out.empty()))
    throw UsageError("a new measurement needs --rig, --sample and --out (or --resume DIR)");
  if (!resume && (a.sample.empty() || a.sample.find_first_of("/\\\n") != std::string::npos))
    throw UsageError("--sample must be a non-empty name without '/', '\\' or newlines");

  if (!resume) {
    // A new session folder: never an input, never inside another session or a library (the
    // folder itself, when it already holds a session, is refused by SessionDir::create with
    // the --resume command to continue it).
    OutputSpec out("--out", a.out);
    out.folder = true;
    out.create_parents = true;
    fit::OutputGuard().input("--rig", a.rig).input("--sim-paint", a.sim_paint).output(out, fs::path(a.out)).check();
  }
  std::optional<acq::SessionDir> session;
  std::string rig_path = a.rig;
  if (resume) {
    session.emplace(acq::SessionDir::open(a.resume));
    if (rig_path.empty()) rig_path = session->manifest().rig_file;
  }
  RigConfig rig = load_rig(rig_path);
  if (resume && session->manifest().rig_sha256 != sha256_file(rig.file))
    spdlog::warn("{} changed since the session started; the session's plan is kept, devices and calibration come "
                 "from the current file",
                 rig.file.string());

  const bool uncalibrated = resume ? session->manifest().options.uncalibrated : a.uncalibrated;
  const bool adaptive = resume ? session->manifest().options.adaptive : a.adaptive;
  acq::MeasureSetup setup = acq::prepare_measurement(rig, uncalibrated, adaptive);

  StopSignals signals;  // before the devices, so GpiodLight chains to it
  RigDevices devices = open_rig_devices(rig);
  Json sim_paint_json;
  if (devices.sim) {
    if (resume) {
      sim_paint_json = session->manifest().options.sim_paint;
      if (sim_paint_json.is_null())
        throw DataError(a.resume + "/session.json: this simulated session does not record its sim paint");
    } else {
      sim_paint_json = brdf::to_json(sim::simulated_paint(a.sim_paint, "--sim-paint").spec);
    }
    apply_sim_paint(devices, sim_paint_json, session ? session->dir() : fs::path(a.out));
  } else if (!a.sim_paint.empty()) {
    throw UsageError("--sim-paint applies only to a simulated rig (devices of kind \"sim\")");
  }
  acq::CameraPreparation cam = acq::prepare_camera(*devices.camera, rig);
  if (resume) acq::check_resume_camera(session->manifest(), cam, a.resume);
  acq::ColourMap colour = acq::prepare_colour(rig, cam.format, uncalibrated);
  const bool bayer = dev::cfa_pattern(cam.format) != dev::CfaPattern::None && !rig.filter_wheel;
  if (!a.demosaic.empty() && !bayer)
    throw UsageError(fmt::format("--demosaic applies to a colour-filter-array camera; this rig's camera records {}{}",
                                 dev::to_string(cam.format), rig.filter_wheel ? " behind a filter wheel" : ""));
  if (resume && !a.demosaic.empty())
    throw UsageError("--demosaic cannot change a session's demosaicing: --resume keeps the session's");
  if (bayer) {
    const std::string method = resume ? session->manifest().options.demosaic : a.demosaic;
    if (!method.empty())
      colour.interpolation = acq::mosaic_interpolation_from_string(
          method, resume ? a.resume + "/session.json: key 'options.demosaic'" : std::string("--demosaic"));
  }

  if (!resume) {
    acq::ManifestInput in;
    in.sample = a.sample;
    in.notes = a.notes;
    in.operator_name = a.operator_name;
    in.devices = {{"turntable", {{"id", devices.turntable->id()}}},
                  {"light", {{"id", devices.light->id()}}},
                  {"camera", {{"id", devices.camera->id()}, {"serial", devices.camera->serial()}}}};
    in.options.keep_raw = a.keep_raw;
    in.options.adaptive = adaptive;
    in.options.uncalibrated = uncalibrated;
    in.options.colour_space = colour.colour_space;
    if (bayer) in.options.demosaic = acq::to_string(colour.interpolation);
    if (devices.sim) in.options.sim_paint = sim_paint_json;
    acq::SessionManifest m = acq::make_manifest(rig, setup, cam, in);
    session.emplace(acq::SessionDir::create(a.out, std::move(m)));
  }

  acq::RunnerOptions ro;
  ro.keep_raw = resume ? session->manifest().options.keep_raw : a.keep_raw;
  ro.max_retries = a.max_retries;
  acq::BracketMerger merge(setup.hdr, dev::bit_depth(cam.format), colour);
  acq::Runner runner(*session, {*devices.turntable, *devices.light, *devices.camera, *devices.clock},
                     merge.function());
  if (devices.filter_wheel)
    runner.set_filter_wheel(devices.filter_wheel.get(), dev::filter_wheel_config(*rig.filter_wheel).channel_slot);
  std::unique_ptr<acq::AdaptiveBracketing> planner;
  if (adaptive) {
    planner = acq::make_adaptive_planner(setup, cam, &merge, rig.filter_wheel.has_value());
    runner.set_planner(planner.get());
  }
  Progress progress("measure", session->position_count(), "pos");
  runner.set_progress(&progress);
  say(fmt::format("measuring sample '{}' on rig '{}': {} positions x {} exposures -> {}", session->manifest().sample,
                  rig.name, session->position_count(), session->manifest().exposures_s.size(),
                  session->dir().string()));
  acq::RunSummary s = runner.run(StopSignals::requested());
  progress.finish();
  say(s.describe(session->dir()));
  if (s.complete) return kExitOk;
  return kExitFailed;
}

}  // namespace

void register_measure_commands(CLI::App& app) {
  auto [m, a] = add_command<MeasureArgs>(&app, "measure", kMeasureHelp, run_measure);
  m->add_option("--rig", a->rig, "rig.toml (for --resume: overrides the rig file recorded in the session)");
  m->add_option("--sample", a->sample, "sample name (recorded in the session)")->check(utf8_text());
  m->add_option("--out", a->out, "session folder to create (must be new or empty)");
  m->add_option("--resume", a->resume, "continue the session in this folder");
  m->add_option("--notes", a->notes, "free-text notes recorded in session.json")->check(utf8_text());
  m->add_option("--operator", a->operator_name, "who measured (recorded in session.json)")->check(utf8_text());
  m->add_flag("--keep-raw", a->keep_raw, "also keep every raw frame (16-bit PNG under DIR/raw/)");
  m->add_flag("--adaptive", a->adaptive,
              "adaptive bracketing: skip exposures that add no unsaturated pixel above the noise floor on the sphere\n"
              "(needs calib/camera.json and sphere.json)");
  m->add_flag("--uncalibrated", a->uncalibrated,
              "merge without calib/response.json and dark.json (a linear camera is assumed; not for real measurements)");
  m->add_option("--demosaic", a->demosaic,
                "a Bayer camera's demosaicing: bilinear (default) or gradient-corrected (Malvar-He-Cutler: keeps\n"
                "highlights of a few pixels narrower; docs/colour.md)")
      ->check(CLI::IsMember({"bilinear", "gradient-corrected"}));
  m->add_option("--sim-paint", a->sim_paint, "simulated rig only: paint .toml on the simulated sphere (default: the built-in silver metallic)");
  m->add_option("--max-retries", a->max_retries, "retries of a failed device operation before stopping safely")
      ->check(CLI::Range(0, 20));
}

}  // namespace paintlab::app
