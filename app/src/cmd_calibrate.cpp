// paintlab calibrate {intrinsics,sphere,light,scale,all}: the rig's geometric calibration
// and its absolute scale (docs/calibration.md). Each step reads images from files or
// captures them through the rig's devices, and writes one file of the calibration folder.
//   paintlab calibrate intrinsics --images FILES... --board 9x6 --square 20 --out camera.json
//   paintlab calibrate intrinsics --rig R --capture [--views 24] [--fix-k3 | --free-k3]
//   paintlab calibrate sphere --rig R (--images FILES... | --capture) [--angles 90,270]
//   paintlab calibrate light  --rig R (--images FILES... | --capture) [--angles -150:150:10]
//   paintlab calibrate scale  --rig R (--images FILES... | --capture) --albedo A [--angles -40,0,40]
//   paintlab calibrate all    --rig R (--images DIR | --capture) [--albedo A] [--fix-k3 | --free-k3]
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>

#include "rig_devices.h"
#include "calibrate_support.h"
#include "paintlab/acquisition/calibration_steps.h"
#include "paintlab/calibration/procedure.h"
#include "paintlab/core/input_files.h"
#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/rig.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

Json provenance_devices(const CalibrateContext& c) { return c.session ? c.session->serials : Json::object(); }

fs::path out_file(const RigConfig& rig, const char* name) {
  fs::create_directories(rig.calibration_dir);
  return rig.calibration_dir / name;
}

// Where a step's images come from: the given files, images_dir/<step> under `calibrate all
// --images DIR`, or the devices.
acq::StepImages step_images(CalibrateContext& c, const std::string& step, const std::vector<std::string>& files) {
  acq::StepImages in;
  if (!files.empty()) in.files = expand_input_files(files, "--images", kCalibrationImageExtensions);
  else if (c.images_dir)
    in.files = expand_input_files({(*c.images_dir / step).string()}, "--images", kCalibrationImageExtensions);
  if (in.files.empty() && c.session) {
    c.capture = c.session->capture_rig();
    in.capture = &c.capture;
  }
  in.devices = provenance_devices(c);
  return in;
}

// The images a command reads: --images as given, or every file under `calibrate all
// --images DIR` (one subfolder per step).
fit::OutputGuard images_read(const std::vector<std::string>& images, bool all) {
  fit::OutputGuard guard;
  if (all && images.size() == 1 && fs::is_directory(images[0])) {
    std::vector<fs::path> files;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(images[0], ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec))
      if (it->is_regular_file(ec)) files.push_back(it->path());
    guard.inputs("--images", files);
  } else if (!images.empty()) {
    guard.inputs("--images", expand_input_files(images, "--images", kCalibrationImageExtensions));
  }
  return guard;
}

// ---- the steps ----

struct IntrinsicsArgs {
  std::vector<std::string> images;
  std::string board = "9x6";
  double square_mm = 20.0;
  std::string out;
  // 24: on a long lens the mapping around the sphere, which the light step magnifies, is
  // known to ~0.015 px with 24 views and ~0.06 px with 12 (simulated 50 mm rig).
  int views = 24;
  std::string corner_method = "saddle-fit";
  bool fix_k3 = false;   // k3 = 0
  bool free_k3 = false;  // k3 fitted whatever its uncertainty; neither: decided from the data
};

void run_intrinsics(CalibrateContext& c, const IntrinsicsArgs& a, bool have_rig) {
  const calib::BoardSpec board = calib::BoardSpec::parse(a.board, a.square_mm);
  calib::IntrinsicsOptions o;
  o.corners.method = calib::corner_method_from_string(a.corner_method, "--corner-method");
  if (a.fix_k3 && a.free_k3) throw UsageError("calibrate intrinsics: give --fix-k3 or --free-k3, not both");
  o.fix_k3 = a.fix_k3;
  o.auto_fix_k3 = !a.fix_k3 && !a.free_k3;
  const acq::StepImages in = step_images(c, "intrinsics", a.images);
  if (have_rig) {
    const auto& g = c.rig.geometry;
    o.initial_focal_px = g.focal_length_mm / (g.pixel_size_um * 1e-3);
    const int views = in.files.empty() ? a.views : static_cast<int>(in.files.size());
    o.min_views = std::max(3, std::min(c.rig.tolerances.min_views, views));
  }
  const calib::IntrinsicsResult r = acq::intrinsics_step(in, board, o, a.views);
  const fs::path out = a.out.empty() ? out_file(c.rig, calib::kCameraFile) : fs::path(a.out);
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  r.save(out);
  say(r.describe());
  say("  wrote " + out.string());
}

void run_sphere(CalibrateContext& c, const std::vector<std::string>& files, const std::string& angles) {
  const calib::SphereFit fit = acq::sphere_step(step_images(c, "sphere", files), calib::RigCalibration::load(c.rig),
                                                c.rig, calib::parse_angles(angles, "--angles"));
  const fs::path out = out_file(c.rig, calib::kSphereFile);
  fit.save(out);
  say(fit.describe());
  say("  wrote " + out.string());
}

void run_light(CalibrateContext& c, const std::vector<std::string>& files, const std::string& angles) {
  const calib::LightCalibration l = acq::light_step(step_images(c, "light", files), calib::RigCalibration::load(c.rig),
                                                    c.rig, calib::parse_angles(angles, "--angles"));
  const fs::path out = out_file(c.rig, calib::kLightFile);
  l.save(out);
  say(l.describe());
  say("  wrote " + out.string());
}

void run_scale(CalibrateContext& c, const std::vector<std::string>& files, const std::string& angles) {
  const calib::RigCalibration cal = calib::RigCalibration::load(c.rig);
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile});
  double albedo = c.albedo;
  if (!(albedo > 0) && c.session) albedo = c.session->stage->known_albedo();
  if (!(albedo > 0))
    throw UsageError("calibrate scale: give --albedo, the reference sphere's certified albedo (e.g. 0.99)");
  if (!cal.has(calib::kFlatFile))
    say("  no flat.json: the LED profile is not fitted (taken as uniform); run `paintlab calibrate flat` first to fit it");
  const calib::ScaleCalibration sc =
      acq::scale_step(step_images(c, "scale", files), cal, c.rig, calib::parse_angles(angles, "--angles"), albedo);
  const fs::path out = out_file(c.rig, calib::kScaleFile);
  sc.save(out);
  say(sc.describe());
  say("  wrote " + out.string());
}

struct StepArgs {
  std::string rig;
  std::vector<std::string> images;
  bool capture = false;
  std::string angles;
  double albedo = 0.0;
};

}  // namespace

void register_calibrate_commands(CLI::App& app, std::shared_ptr<CalibrationRunners> runners) {
  CLI::App* group = subcommand_group(app, "calibrate", "Calibrate the rig (writes the rig's calibration folder)");

  // Context for one command: the rig, and the devices when capturing.
  auto context = [](const std::string& rig_file, bool capture, double albedo,
                    std::unique_ptr<CalibSession>* keep) -> CalibrateContext {
    CalibrateContext c;
    c.rig = load_rig(rig_file);
    c.albedo = albedo;
    if (capture) {
      *keep = std::make_unique<CalibSession>(open_calib_session(c.rig, albedo));
      c.session = keep->get();
    }
    return c;
  };

  // --- intrinsics ---
  {
    auto a = std::make_shared<IntrinsicsArgs>();
    auto common = std::make_shared<StepArgs>();
    CLI::App* cmd = group->add_subcommand("intrinsics", calib::procedure_step("intrinsics").summary);
    cmd->add_option("--rig", common->rig, "rig.toml (writes its calib/camera.json)");
    cmd->add_option("--images", a->images, "chessboard photos or folders of them (8 or 16 bit)");
    cmd->add_flag("--capture", common->capture, "capture the views through the rig's camera");
    cmd->add_option("--board", a->board, "inner corners COLSxROWS")->capture_default_str();
    cmd->add_option("--square", a->square_mm, "square side in mm")->capture_default_str();
    cmd->add_option("--out", a->out, "output file (default: the rig's calib/camera.json)");
    cmd->add_option("--views", a->views, "views to capture")->capture_default_str();
    cmd->add_option("--corner-method", a->corner_method, "saddle-fit or opencv-subpix")->capture_default_str();
    cmd->add_flag("--fix-k3", a->fix_k3, "keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
    cmd->add_flag("--free-k3", a->free_k3, "fit k3 whatever its uncertainty");
    on_run(cmd, [a, common, context] {
      if (common->rig.empty()) {
        if (a->images.empty() || a->out.empty())
          throw UsageError("calibrate intrinsics: without --rig give --images FILES... and --out FILE");
        if (common->capture) throw UsageError("calibrate intrinsics: --capture needs --rig");
        check_step_outputs(images_read(a->images, false), "", {"intrinsics"}, a->out);
        CalibrateContext c;
        run_intrinsics(c, *a, false);
        return kExitOk;
      }
      check_step_outputs(images_read(a->images, false), common->rig, {"intrinsics"}, a->out);
      std::unique_ptr<CalibSession> keep;
      CalibrateContext c = context(common->rig, common->capture, 0.0, &keep);
      run_intrinsics(c, *a, true);
      return kExitOk;
    });
    runners->by_step["intrinsics"] = [a](CalibrateContext& c) {
                                 IntrinsicsArgs args = *a;
                                 args.images.clear();
                                 args.out.clear();
                                 if (c.k3 == "fix") args.fix_k3 = true;
                                 if (c.k3 == "free") args.free_k3 = true;
                                 run_intrinsics(c, args, true);
                               };
  }

  // --- sphere, light, scale ---
  // Their help and default angles come from the procedure (calibration/procedure.h).
  struct Geo {
    const char* name;
    void (*run)(CalibrateContext&, const std::vector<std::string>&, const std::string&);
  };
  const Geo geos[] = {
      {"sphere", &run_sphere},
      {"light", &run_light},
      {"scale", &run_scale},
  };
  for (const Geo& g : geos) {
    const calib::ProcedureStep& step = calib::procedure_step(g.name);
    auto a = std::make_shared<StepArgs>();
    a->angles = step.angles;
    CLI::App* cmd = group->add_subcommand(g.name, step.summary);
    cmd->add_option("--rig", a->rig, "rig.toml")->required();
    cmd->add_option("--images", a->images, "images or folders (angles and exposures in the names, see docs)");
    cmd->add_flag("--capture", a->capture, "capture through the rig's devices");
    cmd->add_option("--angles", a->angles, "table angles: a,b,c or START:STOP:STEP (deg)")->capture_default_str();
    if (std::string(g.name) == "scale")
      cmd->add_option("--albedo", a->albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
    auto run = g.run;
    on_run(cmd, [a, run, context, name = std::string(g.name)] {
      if (a->images.empty() == !a->capture) throw UsageError("calibrate " + name + ": give either --images or --capture");
      std::unique_ptr<CalibSession> keep;
      {
        const RigConfig rig = load_rig(a->rig);
        calib::require_step_inputs(rig.calibration_dir, name, rig.file);
      }  // before any device opens
      check_step_outputs(images_read(a->images, false), a->rig, {name});
      CalibrateContext c = context(a->rig, a->capture, a->albedo, &keep);
      run(c, a->images, a->angles);
      return kExitOk;
    });
    const std::string angles = step.angles;
    runners->by_step[g.name] = [run, angles](CalibrateContext& c) { run(c, {}, angles); };
  }

  // --- all ---
  {
    auto a = std::make_shared<StepArgs>();
    auto dir = std::make_shared<std::string>();
    CLI::App* cmd = group->add_subcommand("all", "Every calibration step in order (writes the whole calibration folder)");
    cmd->add_option("--rig", a->rig, "rig.toml")->required();
    cmd->add_option("--images", *dir, "folder with one subfolder per step (intrinsics/, sphere/, light/, scale/, ...)");
    cmd->add_flag("--capture", a->capture, "capture through the rig's devices");
    cmd->add_option("--albedo", a->albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
    auto k3 = std::make_shared<std::pair<bool, bool>>(false, false);
    cmd->add_flag("--fix-k3", k3->first, "intrinsics: keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
    cmd->add_flag("--free-k3", k3->second, "intrinsics: fit k3 whatever its uncertainty");
    on_run(cmd, [a, dir, k3, context, runners] {
      if (dir->empty() == !a->capture) throw UsageError("calibrate all: give either --images DIR or --capture");
      if (k3->first && k3->second) throw UsageError("calibrate all: give --fix-k3 or --free-k3, not both");
      {
        std::vector<std::string> steps;
        for (const calib::ProcedureStep& step : calib::calibration_procedure()) steps.push_back(step.name);
        check_step_outputs(images_read(dir->empty() ? std::vector<std::string>{} : std::vector<std::string>{*dir}, true),
                           a->rig, steps);
      }
      std::unique_ptr<CalibSession> keep;
      CalibrateContext c = context(a->rig, a->capture, a->albedo, &keep);
      if (!dir->empty()) c.images_dir = fs::path(*dir);
      if (k3->first) c.k3 = "fix";
      if (k3->second) c.k3 = "free";
      for (const calib::ProcedureStep& step : calib::calibration_procedure()) {
        const auto run = runners->by_step.find(step.name);
        if (run == runners->by_step.end())
          throw CalibrationError("calibrate all: no command runs the step '" + step.name + "'");
        say(fmt::format("== {} ==", step.name));
        calib::require_step_inputs(c.rig.calibration_dir, step.name, c.rig.file);
        run->second(c);
      }
      if (c.session) c.session->stage->mount(Target::Sample);
      // Steps not registered with `all` (or that write nothing) leave their file missing.
      std::string missing;
      for (const std::string& f : calib::standard_files())
        if (!fs::exists(c.rig.calibration_dir / f))
          missing += fmt::format("\n  {}: run `paintlab calibrate {} --rig {}`", f, calib::calibrate_step_for(f), a->rig);
      if (!missing.empty()) say("still missing from " + c.rig.calibration_dir.string() + ":" + missing);
      say("calibration done: run `paintlab check --rig " + a->rig + "` to see whether the rig is fit to measure");
      return kExitOk;
    });
  }
}

}  // namespace paintlab::app
