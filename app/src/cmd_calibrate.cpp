// paintlab calibrate STEP: the rig's calibration, one step a command, or all of them in the
// procedure's order (calibration/procedure.h; docs/calibration.md, docs/radiometry.md). Each
// step reads images from files or captures them through the rig's devices and writes one
// file of the calibration folder (or --out). The work is acquisition's (calibration_steps.h);
// this file holds the options, opens the devices and prints.
//   paintlab calibrate intrinsics --images FILES... --board 9x6 --square 20 --out camera.json
//   paintlab calibrate intrinsics --rig R --capture [--views 24] [--fix-k3 | --free-k3]
//   paintlab calibrate dark|response|flat --images FILES... (--exposures LIST | --exposure-file F) --out F.json
//   paintlab calibrate dark|response|flat --rig R (--images DIR | --capture)
//   paintlab calibrate sphere --rig R (--images FILES... | --capture) [--angles 90,270]
//   paintlab calibrate light  --rig R (--images FILES... | --capture) [--angles -150:150:10]
//   paintlab calibrate scale  --rig R (--images FILES... | --capture) --albedo A [--angles -40,0,40]
//   paintlab calibrate all    --rig R (--images DIR | --capture) [--albedo A] [--fix-k3 | --free-k3]
//                             (a colour camera: colour.json too, from the chart captured or DIR/colour/)
//   paintlab calibrate colour (--images CHART.exr | --capture) (--rig R | --out colour.json) [--model M] [--reference F]
// With --capture the frames are kept in calib/captures/<step>/; on a simulated rig the
// simulator puts the lens cap, the boards, the references and the diffuser in place, on a
// real rig the technician does when asked.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "calibrate_support.h"
#include "cli.h"
#include "paintlab/acquisition/calibration_steps.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/procedure.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/fitting/output_guard.h"
#include "radiometry_support.h"
#include "rig_devices.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// What every `calibrate STEP` takes (each step's arguments derive from it).
struct StepCommon {
  std::string rig;
  bool capture = false;
  std::string out;
  StackInput input;            // --images (the radiometric steps: with their exposures)
  std::string dark, response;  // --dark, --response: the steps that use them (procedure's `uses`)
  double albedo = 0.0;         // --albedo (scale)
};

// ---- where a step's images come from and where its result goes ----

Json devices_of(const CalibrateContext& c) { return c.session ? c.session->serials : Json::object(); }

// The images: the given files, DIR/<step> under `calibrate all --images DIR`, or the devices.
acq::StepImages step_images(CalibrateContext& c, const std::string& step, const std::vector<std::string>& files) {
  acq::StepImages in;
  if (!files.empty()) in.files = expand_input_files(files, "--images", kCalibrationImageExtensions);
  else if (c.images_dir)
    in.files = expand_input_files({(*c.images_dir / step).string()}, "--images", kCalibrationImageExtensions);
  if (in.files.empty() && c.session) {
    c.capture = c.session->capture_rig();
    in.capture = &c.capture;
  }
  in.devices = devices_of(c);
  return in;
}

// The exposure stack: --images with their exposures, DIR/<step> (with its exposures.txt)
// under `calibrate all --images DIR`, or captured into calib/captures/<step>/.
acq::StackImages step_stack(CalibrateContext& c, const std::string& step, const StackInput& given) {
  acq::StackImages in;
  in.devices = devices_of(c);
  if (!given.images.empty()) {
    in.stack = load_stack_input(given);
  } else if (c.images_dir) {
    StackInput files;
    files.images = {(*c.images_dir / step).string()};
    files.bit_depth = given.bit_depth;
    in.stack = load_stack_input(files);
  } else if (c.session) {
    c.capture = c.session->capture_rig();
    in.capture = &c.capture;
    in.capture_dir = c.rig.calibration_dir / "captures" / step;
  }
  return in;
}

// A calibration file the step uses: the one given, else the rig's when it exists.
std::optional<fs::path> used_file(const CalibrateContext& c, const std::string& given, const char* name) {
  if (!given.empty()) return fs::path(given);
  if (c.has_rig && fs::exists(c.rig.calibration_dir / name)) return c.rig.calibration_dir / name;
  return std::nullopt;
}

// Saves `result` where the step writes (--out, or the rig's calibration folder), says what
// it found, and lets later steps of the same session linearise with it.
template <class Result>
void save_step(CalibrateContext& c, const std::string& step, const Result& result) {
  const fs::path out = c.out.empty() ? c.rig.calibration_dir / calib::procedure_step(step).file : c.out;
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  result.save(out);
  if (c.session) c.session->linearizer.set_calibration(load_radiometry(c.rig));
  say(result.describe());
  if (step == "dark" || step == "flat")
    say("  wrote " + out.string() + " and " + fs::path(out).replace_extension(".exr").string());
  else
    say("  wrote " + out.string());
}

// ---- the steps ----

struct IntrinsicsArgs : StepCommon {
  std::string board = "9x6";
  double square_mm = 20.0;
  // 24: on a long lens the mapping around the sphere, which the light step magnifies, is
  // known to ~0.015 px with 24 views and ~0.06 px with 12 (simulated 50 mm rig).
  int views = 24;
  std::string corner_method = "saddle-fit";
  bool fix_k3 = false;   // k3 = 0
  bool free_k3 = false;  // k3 fitted whatever its uncertainty; neither: decided from the data
};

void run_intrinsics(CalibrateContext& c, const IntrinsicsArgs& a) {
  const calib::BoardSpec board = calib::BoardSpec::parse(a.board, a.square_mm);
  calib::IntrinsicsOptions o;
  o.corners.method = calib::corner_method_from_string(a.corner_method, "--corner-method");
  const bool fix = a.fix_k3 || c.k3 == "fix", free = a.free_k3 || c.k3 == "free";
  if (fix && free) throw UsageError("calibrate intrinsics: give --fix-k3 or --free-k3, not both");
  o.fix_k3 = fix;
  o.auto_fix_k3 = !fix && !free;
  const acq::StepImages in = step_images(c, "intrinsics", c.images);
  if (c.has_rig) {
    const auto& g = c.rig.geometry;
    o.initial_focal_px = g.focal_length_mm / (g.pixel_size_um * 1e-3);
    const int views = in.files.empty() ? a.views : static_cast<int>(in.files.size());
    o.min_views = std::max(3, std::min(c.rig.tolerances.min_views, views));
  }
  save_step(c, "intrinsics", acq::intrinsics_step(in, board, o, a.views));
}

struct DarkArgs : StepCommon {
  double hot_sigma = 6.0;
  int frames = 8;
};

void run_dark(CalibrateContext& c, const DarkArgs& a) {
  calib::DarkOptions opt;
  opt.hot_sigma = a.hot_sigma;
  save_step(c, "dark", acq::dark_step(step_stack(c, "dark", a.input), opt, a.frames));
}

struct ResponseArgs : StepCommon {
  std::string method = "robertson";
  double black = 0.0;
  double saturation = -1.0;
  double floor = -1.0;
  int knots = 256;
  double smoothness = -1.0;
  std::string no_data;
  int count = 16;
  double angle_deg = std::stod(calib::procedure_step("response").angles);  // the procedure's
};

void run_response(CalibrateContext& c, const ResponseArgs& a) {
  calib::ResponseOptions opt;
  opt.method = calib::response_method_from_string(a.method, "--method");
  opt.black_dn = a.black;
  opt.saturation_dn = a.saturation;
  opt.floor_dn = a.floor;
  opt.max_knots = a.knots;
  opt.smoothness = a.smoothness;
  opt.no_data = calib::parse_no_data(a.no_data, "--no-data");
  const std::optional<fs::path> dark_file = used_file(c, a.dark, calib::kDarkFile);
  std::optional<calib::DarkFrame> dark;
  if (dark_file) dark = calib::DarkFrame::load(*dark_file);
  acq::StackImages in = step_stack(c, "response", a.input);
  if (dark_file) in.also_read.push_back(*dark_file);
  const acq::ResponseStep step = acq::response_step(in, opt, dark ? &*dark : nullptr, a.angle_deg, a.count);
  if (step.captured)
    say(fmt::format("response: white reference at {:.3g} ms (brightest pixels at {:.0f} % of the range); bracket "
                    "{:.3g}..{:.3g} ms, {} exposures",
                    1e3 * step.captured->top_s, 100.0 * acq::kResponseTopFill, 1e3 * step.captured->min_s,
                    1e3 * step.captured->max_s, a.count));
  if (step.constant_ratio > 0)
    spdlog::warn("the exposures step by one ratio (x{:.3g}): the data then fix the curve only up to a periodic "
                 "ripple and the smoothness prior decides; a bracket with unequal steps is better "
                 "(docs/radiometry.md)",
                 step.constant_ratio);
  save_step(c, "response", step.curve);
}

struct FlatArgs : StepCommon {
  int frames = 8;
};

void run_flat(CalibrateContext& c, const FlatArgs& a) {
  const std::optional<fs::path> resp_file = used_file(c, a.response, calib::kResponseFile);
  const std::optional<fs::path> dark_file = used_file(c, a.dark, calib::kDarkFile);
  std::optional<calib::ResponseCurve> resp;
  std::optional<calib::DarkFrame> dark;
  if (resp_file) resp = calib::ResponseCurve::load(*resp_file);
  if (dark_file) dark = calib::DarkFrame::load(*dark_file);
  acq::StackImages in = step_stack(c, "flat", a.input);
  for (const auto& f : {resp_file, dark_file})
    if (f) in.also_read.push_back(*f);
  save_step(c, "flat", acq::flat_step(in, resp ? &*resp : nullptr, dark ? &*dark : nullptr, a.frames));
}

// sphere, light, scale: table angles (the procedure's by default).
struct GeometricArgs : StepCommon {
  std::string angles;
};

void run_sphere(CalibrateContext& c, const GeometricArgs& a) {
  save_step(c, "sphere",
            acq::sphere_step(step_images(c, "sphere", c.images), calib::RigCalibration::load(c.rig), c.rig,
                             calib::parse_angles(a.angles, "--angles")));
}

void run_light(CalibrateContext& c, const GeometricArgs& a) {
  save_step(c, "light",
            acq::light_step(step_images(c, "light", c.images), calib::RigCalibration::load(c.rig), c.rig,
                            calib::parse_angles(a.angles, "--angles")));
}

void run_scale(CalibrateContext& c, const GeometricArgs& a) {
  const calib::RigCalibration cal = calib::RigCalibration::load(c.rig);
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile});
  double albedo = c.albedo;
  if (!(albedo > 0) && c.session) albedo = c.session->stage->known_albedo();
  if (!(albedo > 0))
    throw UsageError("calibrate scale: give --albedo, the reference sphere's certified albedo (e.g. 0.99)");
  if (!cal.has(calib::kFlatFile))
    say("  no flat.json: the LED profile is not fitted (taken as uniform); run `paintlab calibrate flat` first to fit it");
  save_step(c, "scale",
            acq::scale_step(step_images(c, "scale", c.images), cal, c.rig, calib::parse_angles(a.angles, "--angles"),
                            albedo));
}

// ---- the commands ----

// What a step reads besides the rig: the images, the exposure file, and the calibration files
// it linearises with (given, or the rig's), checked against what it writes.
fit::OutputGuard step_inputs(const std::string& step, const StepCommon& a, const std::optional<RigConfig>& rig) {
  fit::OutputGuard guard;
  if (!a.input.images.empty())
    guard.inputs("--images", expand_input_files(a.input.images, "--images", kCalibrationImageExtensions));
  guard.input("--exposure-file", a.input.exposure_file);
  for (const std::string& name : calib::procedure_step(step).uses) {
    const std::string flag = "--" + fs::path(name).stem().string();
    const std::string& given = name == calib::kDarkFile ? a.dark : a.response;
    if (!given.empty()) guard.input(flag, given);
    else if (rig && fs::exists(rig->calibration_dir / name))
      guard.input("the rig's " + name, rig->calibration_dir / name);
  }
  return guard;
}

// `calibrate STEP` on its own: usage, the files it needs, its outputs against its inputs, the
// devices when capturing (all before any work), then the step.
void run_step_command(const std::string& step, const StepCommon& a, const std::function<void(CalibrateContext&)>& run) {
  const std::string cmd = "calibrate " + step;
  if (a.capture && a.rig.empty()) throw UsageError(cmd + ": --capture needs --rig");
  if (a.capture && !a.input.images.empty()) throw UsageError(cmd + ": give either --images or --capture, not both");
  if (!a.capture && a.input.images.empty()) throw UsageError(cmd + ": give --images (or --rig R --capture)");
  if (a.rig.empty() && a.out.empty())
    throw UsageError(cmd + ": without --rig give --images FILES... and --out FILE (or --rig R to write its calibration folder; give --out to write elsewhere)");
  CalibrateContext c;
  std::optional<RigConfig> rig;
  if (!a.rig.empty()) {
    rig = c.rig = load_rig(a.rig);
    c.has_rig = true;
    calib::require_step_inputs(c.rig.calibration_dir, step, c.rig.file);
  }
  check_step_outputs(step_inputs(step, a, rig), a.rig, {step}, a.out);
  c.out = a.out;
  c.images = a.input.images;
  c.albedo = a.albedo;
  std::unique_ptr<CalibSession> session;
  if (a.capture) {
    session = std::make_unique<CalibSession>(open_calib_session(c.rig, a.albedo));
    c.session = session.get();
  }
  run(c);
}

// `calibrate colour`: the colour matrix from images of a ColorChecker (calibration/colour.h).
struct ColourArgs {
  std::vector<std::string> images;
  std::string rig, out, reference = calib::kColorCheckerReference, model = "matrix";
  bool capture = false;
};

int run_colour(const ColourArgs& a) {
  if (a.rig.empty() && a.out.empty()) throw UsageError("calibrate colour: give --rig R (writes its calibration folder's colour.json) or --out FILE");
  if (a.capture == !a.images.empty()) throw UsageError("calibrate colour: give either --images or --rig R --capture");
  if (a.capture && a.rig.empty()) throw UsageError("calibrate colour: --capture needs --rig");
  const calib::ColourFitOptions o{.model = calib::colour_model_from_string(a.model, "--model")};
  acq::StepImages in;
  if (!a.capture) in.files = expand_input_files(a.images, "--images", {".exr"});
  OutputSpec out(a.out.empty() ? "--rig" : "--out", a.out.empty() ? load_rig(a.rig).calibration_dir / calib::kColourFile : fs::path(a.out));
  out.create_parents = true;
  fit::OutputGuard().inputs("--images", in.files).input("--reference", a.reference).output(out).check();
  std::unique_ptr<CalibSession> session;
  acq::CalibrationRig rig;
  if (a.capture) {
    session = std::make_unique<CalibSession>(open_calib_session(load_rig(a.rig), 0.0));
    rig = session->capture_rig();
    in.capture = &rig;
    in.devices = session->serials;
  }
  const calib::ColourCalibration cal = acq::colour_step(in, calib::ChartReference::load(a.reference), o);
  if (out.path.has_parent_path()) fs::create_directories(out.path.parent_path());
  cal.save(out.path);
  say(cal.describe() + "\n  wrote " + out.path.string());
  return kExitOk;
}

// `calibrate all`: images from DIR/<step> or captured; the intrinsics' k3 choice.
struct AllArgs : StepCommon {
  std::string images_dir;
  bool fix_k3 = false, free_k3 = false;
};

// What `calibrate all` runs for each step (with the steps' defaults).
using Runners = std::map<std::string, std::function<void(CalibrateContext&)>>;

// `calibrate STEP` with the options every step has: --images (the radiometric steps: with
// their exposures), --rig, --capture, and --out where the rig is not required; it runs
// `run` with the arguments given, and `calibrate all` runs it with `defaults`.
template <class Args>
std::pair<CLI::App*, Args*> add_step(CLI::App* group, Runners& all, const std::string& step,
                                     void (*run)(CalibrateContext&, const Args&), const Args& defaults = {}) {
  const calib::ProcedureStep& p = calib::procedure_step(step);
  const bool stack = step == "dark" || step == "response" || step == "flat";
  const bool geometric = step == "sphere" || step == "light" || step == "scale";  // they need the rig
  auto [cmd, a] = add_command<Args>(group, step, p.summary, [step, run](const Args& args) {
    run_step_command(step, args, [&](CalibrateContext& c) { run(c, args); });
    return kExitOk;
  });
  *a = defaults;
  if (stack) add_stack_options(cmd, &a->input);
  else cmd->add_option("--images", a->input.images, "images or folders (angles and exposures in the names, see docs)");
  CLI::Option* rig = cmd->add_option("--rig", a->rig, "rig.toml: writes its calibration folder's " + p.file);
  cmd->add_flag("--capture", a->capture, "capture through the rig's devices (needs --rig)");
  if (geometric) rig->required();
  else cmd->add_option("--out", a->out, "output file (default with --rig: the rig's " + p.file + ")");
  all[step] = [run, defaults](CalibrateContext& c) { run(c, defaults); };
  return {cmd, a};
}

}  // namespace

void register_calibrate_commands(CLI::App& app) {
  CLI::App* group = subcommand_group(app, "calibrate", "Calibrate the rig (writes the rig's calibration folder)");
  auto runners = std::make_shared<Runners>();

  auto [intrinsics, i] = add_step<IntrinsicsArgs>(group, *runners, "intrinsics", run_intrinsics);
  intrinsics->get_option("--images")->description("chessboard photos or folders of them (8 or 16 bit)");
  intrinsics->add_option("--board", i->board, "inner corners COLSxROWS")->capture_default_str();
  intrinsics->add_option("--square", i->square_mm, "square side in mm")->capture_default_str();
  intrinsics->add_option("--views", i->views, "views to capture")->capture_default_str();
  intrinsics->add_option("--corner-method", i->corner_method, "saddle-fit or opencv-subpix")->capture_default_str();
  intrinsics->add_flag("--fix-k3", i->fix_k3,
                       "keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
  intrinsics->add_flag("--free-k3", i->free_k3, "fit k3 whatever its uncertainty");

  auto [dark, d] = add_step<DarkArgs>(group, *runners, "dark", run_dark);
  dark->add_option("--hot-sigma", d->hot_sigma, "hot pixel threshold in robust standard deviations")->capture_default_str();
  dark->add_option("--frames", d->frames, "frames per exposure with --capture (at the bracket's shortest and longest)")
      ->capture_default_str();

  auto [response, r] = add_step<ResponseArgs>(group, *runners, "response", run_response);
  response->add_option("--method", r->method, "robertson (default) or debevec (log domain; better for gamma-encoded images)");
  response->add_option("--dark", r->dark, "dark.json: subtract the per-pixel dark level (default with --rig: its dark.json)");
  response->add_option("--black", r->black, "black level (DN) subtracted when there is no dark frame");
  response->add_option("--saturation", r->saturation, "raw value treated as saturated (default: detected)");
  response->add_option("--floor", r->floor, "noise floor (DN above black) below which values carry no weight");
  response->add_option("--knots", r->knots, "curve knots for 10..16-bit data (8-bit: one per value)")->capture_default_str();
  response->add_option("--smoothness", r->smoothness, "curvature penalty (default: the method's)");
  response->add_option("--no-data", r->no_data, "colour R,G,B (or one value) that marks pixels without data");
  response->add_option("--count", r->count, "exposures to capture with --capture")->capture_default_str();
  response->add_option("--angle", r->angle_deg, "table angle for --capture (deg; the LED lights the reference from the side)")
      ->capture_default_str();

  auto [flat, f] = add_step<FlatArgs>(group, *runners, "flat", run_flat);
  flat->add_option("--response", f->response, "response.json to linearise with (default with --rig: its response.json)");
  flat->add_option("--dark", f->dark, "dark.json to subtract (default with --rig: its dark.json)");
  flat->add_option("--frames", f->frames, "frames to capture with --capture (>= 2 also gives the conversion gain)")
      ->capture_default_str();

  for (auto [step, run] : {std::pair{"sphere", &run_sphere}, {"light", &run_light}, {"scale", &run_scale}}) {
    GeometricArgs defaults;
    defaults.angles = calib::procedure_step(step).angles;
    auto [cmd, g] = add_step<GeometricArgs>(group, *runners, step, run, defaults);
    cmd->add_option("--angles", g->angles, "table angles: a,b,c or START:STOP:STEP (deg)")->capture_default_str();
    if (std::string(step) == "scale")
      cmd->add_option("--albedo", g->albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
  }

  auto [colour, k] = add_command<ColourArgs>(group, "colour", "The colour matrix from a ColorChecker 24 (writes colour.json)", run_colour);
  colour->add_option("--images", k->images, "linear RGB EXR images of the chart (hdr merge of a colour stack)");
  colour->add_flag("--capture", k->capture, "photograph the chart through the rig's colour camera (needs --rig)");
  colour->add_option("--rig", k->rig, "rig.toml: writes its calibration folder's colour.json");
  colour->add_option("--out", k->out, "output file (instead of --rig)");
  colour->add_option("--reference", k->reference, "the chart's CGATS reference (LAB_L.. or XYZ_X..)")->capture_default_str();
  colour->add_option("--model", k->model, "matrix, root-polynomial-2 or root-polynomial-3")->capture_default_str();

  auto [all, a] = add_command<AllArgs>(
      group, "all", "Every calibration step in order (writes the whole calibration folder)",
      [runners](const AllArgs& args) {
        const std::string& dir = args.images_dir;
        if (dir.empty() == !args.capture) throw UsageError("calibrate all: give either --images DIR or --capture");
        if (args.fix_k3 && args.free_k3) throw UsageError("calibrate all: give --fix-k3 or --free-k3, not both");
        std::vector<std::string> steps;
        for (const calib::ProcedureStep& step : calib::calibration_procedure()) steps.push_back(step.name);
        check_step_outputs(fit::OutputGuard().input_tree("--images", dir), args.rig, steps);  // every file under DIR
        CalibrateContext c;
        c.rig = load_rig(args.rig);
        c.has_rig = true;
        c.albedo = args.albedo;
        if (!dir.empty()) c.images_dir = fs::path(dir);
        c.k3 = args.fix_k3 ? "fix" : args.free_k3 ? "free" : "";
        std::unique_ptr<CalibSession> session;
        if (args.capture) {
          session = std::make_unique<CalibSession>(open_calib_session(c.rig, args.albedo));
          c.session = session.get();
        }
        for (const std::string& step : steps) {
          say(fmt::format("== {} ==", step));
          calib::require_step_inputs(c.rig.calibration_dir, step, c.rig.file);
          runners->at(step)(c);
        }
        // A colour camera's (or filter wheel's) colour matrix last (linearised with everything
        // above): the chart captured, or DIR/colour/ when it holds the chart's images.
        const bool colour = c.rig.filter_wheel || dev::cfa_pattern(dev::camera_config(c.rig.camera, c.rig.geometry)
                                                                      .pixel_format) != dev::CfaPattern::None;
        if (colour && (c.session || fs::is_directory(*c.images_dir / "colour"))) {
          say("== colour ==");
          const calib::ColourCalibration cal = acq::colour_step(
              step_images(c, "colour", {}), calib::ChartReference::load(calib::kColorCheckerReference), {});
          cal.save(c.rig.calibration_dir / calib::kColourFile);
          say(cal.describe() + "\n  wrote " + (c.rig.calibration_dir / calib::kColourFile).string());
        }
        if (c.session) c.session->stage->mount(Target::Sample);
        say("calibration done: run `paintlab check --rig " + args.rig + "` to see whether the rig is fit to measure");
        return kExitOk;
      });
  all->add_option("--rig", a->rig, "rig.toml")->required();
  all->add_option("--images", a->images_dir, "folder with one subfolder per step (intrinsics/, dark/, response/, ...)");
  all->add_flag("--capture", a->capture, "capture through the rig's devices");
  all->add_option("--albedo", a->albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
  all->add_flag("--fix-k3", a->fix_k3,
                "intrinsics: keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
  all->add_flag("--free-k3", a->free_k3, "intrinsics: fit k3 whatever its uncertainty");
}

}  // namespace paintlab::app
