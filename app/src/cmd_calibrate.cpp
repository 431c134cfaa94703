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
#include "paintlab/calibration/procedure.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/rig.h"
#include "paintlab/fitting/output_guard.h"
#include "radiometry_support.h"
#include "rig_devices.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// What every `calibrate STEP` takes.
struct StepCommon {
  std::string rig;
  bool capture = false;
  std::string out;
  StackInput input;  // --images (the radiometric steps: with their exposures)
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

struct IntrinsicsArgs {
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

struct DarkArgs {
  double hot_sigma = 6.0;
  int frames = 8;
};

void run_dark(CalibrateContext& c, const DarkArgs& a, const StackInput& input) {
  calib::DarkOptions opt;
  opt.hot_sigma = a.hot_sigma;
  save_step(c, "dark", acq::dark_step(step_stack(c, "dark", input), opt, a.frames));
}

struct ResponseArgs {
  std::string method = "robertson";
  std::string dark;
  double black = 0.0;
  double saturation = -1.0;
  double floor = -1.0;
  int knots = 256;
  double smoothness = -1.0;
  std::string no_data;
  int count = 16;
  double angle_deg = std::stod(calib::procedure_step("response").angles);  // the procedure's
};

void run_response(CalibrateContext& c, const ResponseArgs& a, const StackInput& input) {
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
  acq::StackImages in = step_stack(c, "response", input);
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

struct FlatArgs {
  std::string response;
  std::string dark;
  int frames = 8;
};

void run_flat(CalibrateContext& c, const FlatArgs& a, const StackInput& input) {
  const std::optional<fs::path> resp_file = used_file(c, a.response, calib::kResponseFile);
  const std::optional<fs::path> dark_file = used_file(c, a.dark, calib::kDarkFile);
  std::optional<calib::ResponseCurve> resp;
  std::optional<calib::DarkFrame> dark;
  if (resp_file) resp = calib::ResponseCurve::load(*resp_file);
  if (dark_file) dark = calib::DarkFrame::load(*dark_file);
  acq::StackImages in = step_stack(c, "flat", input);
  for (const auto& f : {resp_file, dark_file})
    if (f) in.also_read.push_back(*f);
  save_step(c, "flat", acq::flat_step(in, resp ? &*resp : nullptr, dark ? &*dark : nullptr, a.frames));
}

void run_sphere(CalibrateContext& c, const std::string& angles) {
  save_step(c, "sphere",
            acq::sphere_step(step_images(c, "sphere", c.images), calib::RigCalibration::load(c.rig), c.rig,
                             calib::parse_angles(angles, "--angles")));
}

void run_light(CalibrateContext& c, const std::string& angles) {
  save_step(c, "light",
            acq::light_step(step_images(c, "light", c.images), calib::RigCalibration::load(c.rig), c.rig,
                            calib::parse_angles(angles, "--angles")));
}

void run_scale(CalibrateContext& c, const std::string& angles) {
  const calib::RigCalibration cal = calib::RigCalibration::load(c.rig);
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile});
  double albedo = c.albedo;
  if (!(albedo > 0) && c.session) albedo = c.session->stage->known_albedo();
  if (!(albedo > 0))
    throw UsageError("calibrate scale: give --albedo, the reference sphere's certified albedo (e.g. 0.99)");
  if (!cal.has(calib::kFlatFile))
    say("  no flat.json: the LED profile is not fitted (taken as uniform); run `paintlab calibrate flat` first to fit it");
  save_step(c, "scale",
            acq::scale_step(step_images(c, "scale", c.images), cal, c.rig, calib::parse_angles(angles, "--angles"),
                            albedo));
}

// ---- the commands ----

// What a step reads besides the rig: the images, the exposure file, and the calibration files
// it linearises with (given, or the rig's), checked against what it writes.
fit::OutputGuard step_inputs(const StepCommon& a, const std::optional<RigConfig>& rig,
                             const std::vector<std::pair<const char*, std::string>>& used) {
  fit::OutputGuard guard;
  if (!a.input.images.empty())
    guard.inputs("--images", expand_input_files(a.input.images, "--images", kCalibrationImageExtensions));
  guard.input("--exposure-file", a.input.exposure_file);
  for (const auto& [name, given] : used) {
    const std::string flag = std::string("--") + fs::path(name).stem().string();
    if (!given.empty()) guard.input(flag, given);
    else if (rig && fs::exists(rig->calibration_dir / name))
      guard.input(std::string("the rig's ") + name, rig->calibration_dir / name);
  }
  return guard;
}

// `calibrate STEP` on its own: usage, the files it needs, its outputs against its inputs, the
// devices when capturing (all before any work), then the step.
void run_step_command(const std::string& step, const StepCommon& a, double albedo,
                      const std::vector<std::pair<const char*, std::string>>& used,
                      const std::function<void(CalibrateContext&)>& run) {
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
  check_step_outputs(step_inputs(a, rig, used), a.rig, {step}, a.out);
  c.out = a.out;
  c.images = a.input.images;
  c.albedo = albedo;
  std::unique_ptr<CalibSession> session;
  if (a.capture) {
    session = std::make_unique<CalibSession>(open_calib_session(c.rig, albedo));
    c.session = session.get();
  }
  run(c);
}

// Adds the options every step has; `stack`: the radiometric steps' exposures too.
void add_common(CLI::App* cmd, StepCommon* a, const std::string& step, bool stack,
                const char* images_help = "images or folders (angles and exposures in the names, see docs)") {
  const std::string file = calib::procedure_step(step).file;
  if (stack)
    add_stack_options(cmd, &a->input);
  else
    cmd->add_option("--images", a->input.images, images_help);
  cmd->add_option("--rig", a->rig, "rig.toml: writes its calibration folder's " + file);
  cmd->add_flag("--capture", a->capture, "capture through the rig's devices (needs --rig)");
}

void add_out(CLI::App* cmd, StepCommon* a, const std::string& step) {
  cmd->add_option("--out", a->out, "output file (default with --rig: the rig's " + calib::procedure_step(step).file + ")");
}

}  // namespace

void register_calibrate_commands(CLI::App& app) {
  CLI::App* group = subcommand_group(app, "calibrate", "Calibrate the rig (writes the rig's calibration folder)");
  // What `calibrate all` runs for each step (with the steps' defaults).
  auto runners = std::make_shared<std::map<std::string, std::function<void(CalibrateContext&)>>>();
  auto step_command = [&](const char* step) { return group->add_subcommand(step, calib::procedure_step(step).summary); };

  {
    auto common = std::make_shared<StepCommon>();
    auto a = std::make_shared<IntrinsicsArgs>();
    CLI::App* cmd = step_command("intrinsics");
    add_common(cmd, common.get(), "intrinsics", false, "chessboard photos or folders of them (8 or 16 bit)");
    add_out(cmd, common.get(), "intrinsics");
    cmd->add_option("--board", a->board, "inner corners COLSxROWS")->capture_default_str();
    cmd->add_option("--square", a->square_mm, "square side in mm")->capture_default_str();
    cmd->add_option("--views", a->views, "views to capture")->capture_default_str();
    cmd->add_option("--corner-method", a->corner_method, "saddle-fit or opencv-subpix")->capture_default_str();
    cmd->add_flag("--fix-k3", a->fix_k3, "keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
    cmd->add_flag("--free-k3", a->free_k3, "fit k3 whatever its uncertainty");
    on_run(cmd, [common, a] {
      run_step_command("intrinsics", *common, 0.0, {}, [a](CalibrateContext& c) { run_intrinsics(c, *a); });
      return kExitOk;
    });
    (*runners)["intrinsics"] = [](CalibrateContext& c) { run_intrinsics(c, IntrinsicsArgs{}); };
  }
  {
    auto common = std::make_shared<StepCommon>();
    auto a = std::make_shared<DarkArgs>();
    CLI::App* cmd = step_command("dark");
    add_common(cmd, common.get(), "dark", true);
    add_out(cmd, common.get(), "dark");
    cmd->add_option("--hot-sigma", a->hot_sigma, "hot pixel threshold in robust standard deviations")->capture_default_str();
    cmd->add_option("--frames", a->frames, "frames per exposure with --capture (at the bracket's shortest and longest)")
        ->capture_default_str();
    on_run(cmd, [common, a] {
      run_step_command("dark", *common, 0.0, {}, [&](CalibrateContext& c) { run_dark(c, *a, common->input); });
      return kExitOk;
    });
    (*runners)["dark"] = [](CalibrateContext& c) { run_dark(c, DarkArgs{}, StackInput{}); };
  }
  {
    auto common = std::make_shared<StepCommon>();
    auto a = std::make_shared<ResponseArgs>();
    CLI::App* cmd = step_command("response");
    add_common(cmd, common.get(), "response", true);
    add_out(cmd, common.get(), "response");
    cmd->add_option("--method", a->method, "robertson (default) or debevec (log domain; better for gamma-encoded images)");
    cmd->add_option("--dark", a->dark, "dark.json: subtract the per-pixel dark level (default with --rig: its dark.json)");
    cmd->add_option("--black", a->black, "black level (DN) subtracted when there is no dark frame");
    cmd->add_option("--saturation", a->saturation, "raw value treated as saturated (default: detected)");
    cmd->add_option("--floor", a->floor, "noise floor (DN above black) below which values carry no weight");
    cmd->add_option("--knots", a->knots, "curve knots for 10..16-bit data (8-bit: one per value)")->capture_default_str();
    cmd->add_option("--smoothness", a->smoothness, "curvature penalty (default: the method's)");
    cmd->add_option("--no-data", a->no_data, "colour R,G,B (or one value) that marks pixels without data");
    cmd->add_option("--count", a->count, "exposures to capture with --capture")->capture_default_str();
    cmd->add_option("--angle", a->angle_deg, "table angle for --capture (deg; the LED lights the reference from the side)")
        ->capture_default_str();
    on_run(cmd, [common, a] {
      run_step_command("response", *common, 0.0, {{calib::kDarkFile, a->dark}},
                       [&](CalibrateContext& c) { run_response(c, *a, common->input); });
      return kExitOk;
    });
    (*runners)["response"] = [](CalibrateContext& c) { run_response(c, ResponseArgs{}, StackInput{}); };
  }
  {
    auto common = std::make_shared<StepCommon>();
    auto a = std::make_shared<FlatArgs>();
    CLI::App* cmd = step_command("flat");
    add_common(cmd, common.get(), "flat", true);
    add_out(cmd, common.get(), "flat");
    cmd->add_option("--response", a->response, "response.json to linearise with (default with --rig: its response.json)");
    cmd->add_option("--dark", a->dark, "dark.json to subtract (default with --rig: its dark.json)");
    cmd->add_option("--frames", a->frames, "frames to capture with --capture (>= 2 also gives the conversion gain)")
        ->capture_default_str();
    on_run(cmd, [common, a] {
      run_step_command("flat", *common, 0.0, {{calib::kDarkFile, a->dark}, {calib::kResponseFile, a->response}},
                       [&](CalibrateContext& c) { run_flat(c, *a, common->input); });
      return kExitOk;
    });
    (*runners)["flat"] = [](CalibrateContext& c) { run_flat(c, FlatArgs{}, StackInput{}); };
  }
  // sphere, light, scale: their help and default angles come from the procedure.
  const std::pair<const char*, void (*)(CalibrateContext&, const std::string&)> geometric[] = {
      {"sphere", &run_sphere}, {"light", &run_light}, {"scale", &run_scale}};
  for (const auto& geo : geometric) {
    const char* name = geo.first;
    const auto run = geo.second;  // a plain variable: lambdas capture it (not a structured binding)
    const std::string step = name, angles = calib::procedure_step(step).angles;
    auto common = std::make_shared<StepCommon>();
    auto chosen = std::make_shared<std::string>(angles);
    auto albedo = std::make_shared<double>(0.0);
    CLI::App* cmd = step_command(name);
    add_common(cmd, common.get(), step, false);
    cmd->get_option("--rig")->required();
    cmd->add_option("--angles", *chosen, "table angles: a,b,c or START:STOP:STEP (deg)")->capture_default_str();
    if (step == "scale")
      cmd->add_option("--albedo", *albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
    on_run(cmd, [step, common, chosen, albedo, run] {
      run_step_command(step, *common, *albedo, {}, [&](CalibrateContext& c) { run(c, *chosen); });
      return kExitOk;
    });
    (*runners)[step] = [run, angles](CalibrateContext& c) { run(c, angles); };
  }

  auto a = std::make_shared<StepCommon>();
  auto images_dir = std::make_shared<std::string>();
  auto albedo = std::make_shared<double>(0.0);
  auto k3 = std::make_shared<std::pair<bool, bool>>(false, false);
  CLI::App* cmd = group->add_subcommand("all", "Every calibration step in order (writes the whole calibration folder)");
  cmd->add_option("--rig", a->rig, "rig.toml")->required();
  cmd->add_option("--images", *images_dir, "folder with one subfolder per step (intrinsics/, dark/, response/, ...)");
  cmd->add_flag("--capture", a->capture, "capture through the rig's devices");
  cmd->add_option("--albedo", *albedo, "the reference sphere's certified albedo (simulated rigs: 0.99)");
  cmd->add_flag("--fix-k3", k3->first, "intrinsics: keep k3 = 0 (default: fixed when the free fit leaves it less certain than its value)");
  cmd->add_flag("--free-k3", k3->second, "intrinsics: fit k3 whatever its uncertainty");
  on_run(cmd, [a, images_dir, albedo, k3, runners] {
    const std::string& dir = *images_dir;
    if (dir.empty() == !a->capture) throw UsageError("calibrate all: give either --images DIR or --capture");
    if (k3->first && k3->second) throw UsageError("calibrate all: give --fix-k3 or --free-k3, not both");
    std::vector<std::string> steps;
    for (const calib::ProcedureStep& step : calib::calibration_procedure()) steps.push_back(step.name);
    {
      // Every file under DIR (one subfolder per step) is read.
      fit::OutputGuard read;
      std::error_code ec;
      if (!dir.empty())
        for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
             it.increment(ec))
          if (it->is_regular_file(ec)) read.input("--images", it->path());
      check_step_outputs(read, a->rig, steps);
    }
    CalibrateContext c;
    c.rig = load_rig(a->rig);
    c.has_rig = true;
    c.albedo = *albedo;
    if (!dir.empty()) c.images_dir = fs::path(dir);
    if (k3->first) c.k3 = "fix";
    if (k3->second) c.k3 = "free";
    std::unique_ptr<CalibSession> session;
    if (a->capture) {
      session = std::make_unique<CalibSession>(open_calib_session(c.rig, *albedo));
      c.session = session.get();
    }
    for (const std::string& step : steps) {
      say(fmt::format("== {} ==", step));
      calib::require_step_inputs(c.rig.calibration_dir, step, c.rig.file);
      runners->at(step)(c);
    }
    if (c.session) c.session->stage->mount(Target::Sample);
    say("calibration done: run `paintlab check --rig " + a->rig + "` to see whether the rig is fit to measure");
    return kExitOk;
  });
}

}  // namespace paintlab::app
