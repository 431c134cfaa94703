// paintlab calibrate response|dark|flat: the radiometric calibration (docs/radiometry.md).
//   paintlab calibrate response --images FILES... (--exposures LIST | --exposure-file F) --out response.json
//   paintlab calibrate response --rig R (--images DIR | --capture)       -> calib/response.json
//   paintlab calibrate dark     --images FILES... (--exposures ...) --out dark.json | --rig R (--images DIR | --capture)
//   paintlab calibrate flat     --images FILES... (--exposures ...) --out flat.json | --rig R (--images DIR | --capture)
// The three are also steps of `paintlab calibrate all` (dark, then response, then flat, before
// the geometric steps, which linearise their images with them). With --capture the frames are
// taken through the rig's devices and kept in calib/captures/<step>/ (with exposures.txt);
// on a simulated rig the simulator puts the lens cap, the white reference and the diffuser
// in place, on a real rig the technician does when asked.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <memory>
#include <optional>

#include "rig_devices.h"
#include "calibrate_support.h"
#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/acquisition/calibration_steps.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/procedure.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/result.h"
#include "paintlab/core/rig.h"
#include "radiometry_support.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

struct Common {
  StackInput input;
  std::string rig;
  bool capture = false;
  std::string out;
};

void add_common(CLI::App* cmd, Common* c, const char* what) {
  add_stack_options(cmd, &c->input);
  cmd->add_option("--rig", c->rig, std::string("rig.toml: writes its calibration folder's ") + what);
  cmd->add_flag("--capture", c->capture, "capture the frames through the rig's devices (needs --rig)");
  cmd->add_option("--out", c->out, std::string("output file (default with --rig: the rig's ") + what + ")");
}

// Where the result goes, checked before any work so that bad usage writes nothing.
fs::path output_path(const Common& c, const std::optional<RigConfig>& rig, const char* file, const std::string& cmd) {
  if (c.capture && !rig) throw UsageError(cmd + ": --capture needs --rig");
  if (c.capture && !c.input.images.empty()) throw UsageError(cmd + ": give either --images or --capture, not both");
  if (!c.capture && c.input.images.empty()) throw UsageError(cmd + ": give --images (or --rig R --capture)");
  if (!c.out.empty()) return c.out;
  if (rig) return rig->calibration_dir / file;
  throw UsageError(cmd + ": give --out FILE (or --rig R)");
}

// One run of a step: the rig (when given), the devices (when capturing) or the folder of
// `calibrate all --images DIR`, and the output file.
struct StepRun {
  CalibrateContext* context = nullptr;  // null: files only, no rig
  fs::path out;
  const char* step = "";

  // The frames: --images, DIR/<step> (with its exposures.txt) under `calibrate all --images
  // DIR`, or captured into calib/captures/<step>/.
  acq::StackImages images(const Common& a) const {
    acq::StackImages in;
    if (context && context->session) in.devices = context->session->serials;
    if (!a.input.images.empty()) {
      in.stack = load_stack_input(a.input);
    } else if (context && context->images_dir) {
      StackInput files;
      files.images = {(*context->images_dir / step).string()};
      files.bit_depth = a.input.bit_depth;
      in.stack = load_stack_input(files);
    } else if (context && context->session) {
      context->capture = context->session->capture_rig();
      in.capture = &context->capture;
      in.capture_dir = context->rig.calibration_dir / "captures" / step;
    }
    return in;
  }
  // A calibration file of the rig, when there is a rig and the file exists.
  std::optional<fs::path> rig_file(const char* name) const {
    if (context && fs::exists(context->rig.calibration_dir / name)) return context->rig.calibration_dir / name;
    return std::nullopt;
  }
  // Later steps of the same session linearise with what this one wrote.
  void refresh() const {
    if (context && context->session) context->session->linearizer.set_calibration(load_radiometry(context->rig));
  }
};

// --- dark ------------------------------------------------------------------------------

struct DarkArgs : Common {
  double hot_sigma = 6.0;
  int frames = 8;
};

void run_dark(const DarkArgs& a, const StepRun& run) {
  calib::DarkOptions opt;
  opt.hot_sigma = a.hot_sigma;
  const calib::DarkFrame d = acq::dark_step(run.images(a), opt, a.frames);
  if (run.out.has_parent_path()) fs::create_directories(run.out.parent_path());
  d.save(run.out);
  run.refresh();
  say(d.describe());
  say("  wrote " + run.out.string() + " and " + fs::path(run.out).replace_extension(".exr").string());
}

// --- response --------------------------------------------------------------------------

struct ResponseArgs : Common {
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

void run_response(const ResponseArgs& a, const StepRun& run) {
  calib::ResponseOptions opt;
  opt.method = calib::response_method_from_string(a.method, "--method");
  opt.black_dn = a.black;
  opt.saturation_dn = a.saturation;
  opt.floor_dn = a.floor;
  opt.max_knots = a.knots;
  opt.smoothness = a.smoothness;
  opt.no_data = calib::parse_no_data(a.no_data, "--no-data");
  std::optional<calib::DarkFrame> dark;
  std::optional<fs::path> dark_file;
  if (!a.dark.empty()) dark_file = fs::path(a.dark);
  else dark_file = run.rig_file(calib::kDarkFile);
  if (dark_file) dark = calib::DarkFrame::load(*dark_file);

  acq::StackImages in = run.images(a);
  if (dark_file) in.also_read.push_back(*dark_file);
  acq::ResponseStep step = acq::response_step(in, opt, dark ? &*dark : nullptr, a.angle_deg, a.count);
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
  const calib::ResponseCurve& r = step.curve;
  if (run.out.has_parent_path()) fs::create_directories(run.out.parent_path());
  r.save(run.out);
  run.refresh();
  say(r.describe());
  say("  wrote " + run.out.string());
}

// --- flat ------------------------------------------------------------------------------

struct FlatArgs : Common {
  std::string response;
  std::string dark;
  int frames = 8;
};

void run_flat(const FlatArgs& a, const StepRun& run) {
  std::optional<fs::path> resp_file, dark_file;
  if (!a.response.empty()) resp_file = fs::path(a.response);
  else resp_file = run.rig_file(calib::kResponseFile);
  if (!a.dark.empty()) dark_file = fs::path(a.dark);
  else dark_file = run.rig_file(calib::kDarkFile);
  std::optional<calib::ResponseCurve> resp;
  std::optional<calib::DarkFrame> dark;
  if (resp_file) resp = calib::ResponseCurve::load(*resp_file);
  if (dark_file) dark = calib::DarkFrame::load(*dark_file);
  acq::StackImages in = run.images(a);
  if (resp_file) in.also_read.push_back(*resp_file);
  if (dark_file) in.also_read.push_back(*dark_file);
  const calib::FlatField f = acq::flat_step(in, resp ? &*resp : nullptr, dark ? &*dark : nullptr, a.frames);
  if (run.out.has_parent_path()) fs::create_directories(run.out.parent_path());
  f.save(run.out);
  run.refresh();
  say(f.describe());
  say("  wrote " + run.out.string() + " and " + fs::path(run.out).replace_extension(".exr").string());
}

// What a step reads besides the rig: the images, the exposure file, the dark frame and
// response it linearises with (given, or the rig's).
template <class Args>
fit::OutputGuard step_inputs(const Args& a, const std::optional<RigConfig>& rig) {
  fit::OutputGuard guard;
  if (!a.input.images.empty())
    guard.inputs("--images", expand_input_files(a.input.images, "--images", kRawImageExtensions));
  guard.input("--exposure-file", a.input.exposure_file);
  auto used = [&](const char* flag, const std::string& given, const char* name) {
    if (!given.empty()) guard.input(flag, given);
    else if (rig && fs::exists(rig->calibration_dir / name))
      guard.input(std::string("the rig's ") + name, rig->calibration_dir / name);
  };
  if constexpr (requires { a.dark; }) used("--dark", a.dark, calib::kDarkFile);
  if constexpr (requires { a.response; }) used("--response", a.response, calib::kResponseFile);
  return guard;
}

// The stand-alone command: rig and devices as the options say, then the step.
template <class Args>
void run_command(const Args& a, const char* step, const char* file, void (*run)(const Args&, const StepRun&)) {
  std::optional<RigConfig> rig;
  if (!a.rig.empty()) rig = load_rig(a.rig);
  StepRun r;
  r.step = step;
  r.out = output_path(a, rig, file, std::string("calibrate ") + step);
  check_step_outputs(step_inputs(a, rig), a.rig, {step}, a.out.empty() ? fs::path() : r.out);
  CalibrateContext c;
  std::unique_ptr<CalibSession> keep;
  if (rig) {
    c.rig = *rig;
    if (a.capture) {
      keep = std::make_unique<CalibSession>(open_calib_session(*rig, 0.0));
      c.session = keep.get();
    }
    r.context = &c;
  }
  run(a, r);
}

// The step of `paintlab calibrate all`: the command's defaults, the rig's file.
template <class Args>
std::function<void(CalibrateContext&)> all_step(const char* step, const char* file,
                                                void (*run)(const Args&, const StepRun&)) {
  return [step, file, run](CalibrateContext& c) {
            const Args a;  // the defaults (the stand-alone command's options are not parsed under `all`)
            StepRun r;
            r.context = &c;
            r.step = step;
            fs::create_directories(c.rig.calibration_dir);
            r.out = c.rig.calibration_dir / file;
            run(a, r);
          };
}

}  // namespace

void register_calibrate_radiometric_commands(CLI::App& app, CalibrationRunners& runners) {
  CLI::App* group = subcommand_group(app, "calibrate", "Calibrate the rig (writes the rig's calibration folder)");

  {
    auto a = std::make_shared<DarkArgs>();
    CLI::App* cmd = group->add_subcommand("dark", calib::procedure_step("dark").summary);
    add_common(cmd, a.get(), "dark.json");
    cmd->add_option("--hot-sigma", a->hot_sigma, "hot pixel threshold in robust standard deviations")->capture_default_str();
    cmd->add_option("--frames", a->frames, "frames per exposure with --capture (at the bracket's shortest and longest)")
        ->capture_default_str();
    on_run(cmd, [a] {
      run_command<DarkArgs>(*a, "dark", calib::kDarkFile, &run_dark);
      return 0;
    });
    runners.by_step["dark"] = all_step<DarkArgs>("dark", calib::kDarkFile, &run_dark);
  }

  {
    auto a = std::make_shared<ResponseArgs>();
    CLI::App* cmd = group->add_subcommand("response", calib::procedure_step("response").summary);
    add_common(cmd, a.get(), "response.json");
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
    on_run(cmd, [a] {
      run_command<ResponseArgs>(*a, "response", calib::kResponseFile, &run_response);
      return 0;
    });
    runners.by_step["response"] = all_step<ResponseArgs>("response", calib::kResponseFile, &run_response);
  }

  {
    auto a = std::make_shared<FlatArgs>();
    CLI::App* cmd = group->add_subcommand("flat", calib::procedure_step("flat").summary);
    add_common(cmd, a.get(), "flat.json");
    cmd->add_option("--response", a->response, "response.json to linearise with (default with --rig: its response.json)");
    cmd->add_option("--dark", a->dark, "dark.json to subtract (default with --rig: its dark.json)");
    cmd->add_option("--frames", a->frames, "frames to capture with --capture (>= 2 also gives the conversion gain)")
        ->capture_default_str();
    on_run(cmd, [a] {
      run_command<FlatArgs>(*a, "flat", calib::kFlatFile, &run_flat);
      return 0;
    });
    runners.by_step["flat"] = all_step<FlatArgs>("flat", calib::kFlatFile, &run_flat);
  }
}

}  // namespace paintlab::app
