// paintlab calibrate response|dark|flat: the radiometric calibration (docs/radiometry.md).
//   paintlab calibrate response --images FILES... (--exposures LIST | --exposure-file F) --out response.json
//   paintlab calibrate response --rig R (--images DIR | --capture)       -> calib/response.json
//   paintlab calibrate dark     --images FILES... (--exposures ... ) --out dark.json | --rig R (--images DIR | --capture)
//   paintlab calibrate flat     --images FILES... (--exposures ... ) --out flat.json | --rig R --images DIR
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <memory>
#include <optional>

#include "cli.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"
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
  cmd->add_flag("--capture", c->capture, "capture the frames through the rig's camera (needs --rig)");
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

std::optional<RigConfig> load_rig(const Common& c) {
  if (c.rig.empty()) return std::nullopt;
  return RigConfig::load(c.rig);
}

std::vector<std::uint16_t> parse_colour(const std::string& text) {
  std::vector<std::uint16_t> out;
  if (text.empty()) return out;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || end != item.c_str() + item.size() || v < 0 || v > 65535)
      throw UsageError("--no-data: '" + item + "' is not a value 0..65535 (give R,G,B or one value)");
    out.push_back(static_cast<std::uint16_t>(v));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (out.size() != 1 && out.size() != 3) throw UsageError("--no-data: give one value (mono) or R,G,B");
  return out;
}

std::string percent(double v) { return fmt::format("{:.2f} %", 100.0 * v); }

}  // namespace

void register_calibrate_radiometric_commands(CLI::App& app) {
  CLI::App* group = subcommand_group(app, "calibrate", "Calibrate the rig (writes the rig's calibration folder)");

  // --- response ------------------------------------------------------------------------
  {
    struct Args : Common {
      std::string method = "robertson";
      std::string dark;
      double black = 0.0;
      double saturation = -1.0;
      double floor = -1.0;
      int knots = 256;
      double smoothness = -1.0;
      std::string no_data;
      int count = 16;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = group->add_subcommand(
        "response", "Camera response curve from an exposure stack (Robertson's or Debevec's method; writes response.json)");
    add_common(cmd, a.get(), "response.json");
    cmd->add_option("--method", a->method, "robertson (default) or debevec (log domain; better for gamma-encoded images)");
    cmd->add_option("--dark", a->dark, "dark.json: subtract the per-pixel dark level (default with --rig: its dark.json)");
    cmd->add_option("--black", a->black, "black level (DN) subtracted when there is no dark frame");
    cmd->add_option("--saturation", a->saturation, "raw value treated as saturated (default: detected)");
    cmd->add_option("--floor", a->floor, "noise floor (DN above black) below which values carry no weight");
    cmd->add_option("--knots", a->knots, "curve knots for 10..16-bit data (8-bit: one per value)");
    cmd->add_option("--smoothness", a->smoothness, "curvature penalty (default: the method's)");
    cmd->add_option("--no-data", a->no_data, "colour R,G,B (or one value) that marks pixels without data");
    cmd->add_option("--count", a->count, "exposures to capture with --capture");
    on_run(cmd, [a] {
      const auto rig = load_rig(*a);
      const fs::path out = output_path(*a, rig, calib::kResponseFile, "calibrate response");
      calib::ResponseOptions opt;
      opt.method = calib::response_method_from_string(a->method);
      opt.black_dn = a->black;
      opt.saturation_dn = a->saturation;
      opt.floor_dn = a->floor;
      opt.max_knots = a->knots;
      opt.smoothness = a->smoothness;
      opt.no_data = parse_colour(a->no_data);
      opt.check();
      std::optional<calib::DarkFrame> dark;
      fs::path dark_file = a->dark;
      if (dark_file.empty() && rig && fs::exists(rig->calibration_dir / calib::kDarkFile))
        dark_file = rig->calibration_dir / calib::kDarkFile;
      if (!dark_file.empty()) dark = calib::DarkFrame::load(dark_file);

      calib::ExposureStack stack;
      Json devices = Json::object();
      if (a->capture) {
        const auto& t = rig->plan.exposures_s;
        auto got = capture_stack(*rig, calibration_bracket(t.front(), t.back(), a->count), 1, true,
                                 rig->calibration_dir / "captures" / "response");
        stack = std::move(got.stack);
        devices = got.devices;
      } else {
        stack = load_stack_input(a->input);
      }
      double ratio = 0.0;
      if (constant_ratio(stack.exposures_s, &ratio))
        spdlog::warn("the exposures step by one ratio (x{:.3g}): the data then fix the curve only up to a periodic "
                     "ripple and the smoothness prior decides; a bracket with unequal steps is better "
                     "(docs/radiometry.md)",
                     ratio);
      const auto frames = stack.frames();
      calib::ResponseCurve r = calib::recover_response(frames, stack.bit_depth, opt, dark ? &*dark : nullptr);
      std::vector<fs::path> inputs = stack.files;
      if (dark) inputs.push_back(dark_file);
      r.provenance = calib::Provenance::make("response", inputs, devices);
      if (out.has_parent_path()) fs::create_directories(out.parent_path());
      r.save(out);
      double worst_nonlin = 0.0;
      for (double v : r.report.nonlinearity_rel) worst_nonlin = std::max(worst_nonlin, v);
      say(fmt::format("response: {} method, {}-bit, {} channel(s), {} knots, {} images; used range {:.0f}..{:.0f} DN "
                      "(black {:.1f} DN{})",
                      calib::to_string(r.method), r.bit_depth, r.channels, r.knots_dn.size(), frames.size(),
                      r.window.floor_dn, r.window.u_saturation(), r.window.black_dn,
                      r.dark_subtracted ? ", dark frame subtracted" : ""));
      say(fmt::format("  linearity error {} (RMS {}), nonlinearity of the camera {}", percent(r.report.linearity_error_rel),
                      percent(r.report.linearity_rms_rel), percent(worst_nonlin)));
      if (r.noise.known())
        say(fmt::format("  noise: read {:.3g} DN, shot {:.3g} DN/e ({})", r.noise.read_noise_dn, r.noise.gain_dn_per_e,
                        r.noise.source));
      say("wrote " + out.string());
      return 0;
    });
  }

  // --- dark ----------------------------------------------------------------------------
  {
    struct Args : Common {
      double hot_sigma = 6.0;
      int frames = 8;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = group->add_subcommand(
        "dark", "Dark frame (black level per pixel, dark current, read noise) and hot pixels (writes dark.json + dark.exr)");
    add_common(cmd, a.get(), "dark.json");
    cmd->add_option("--hot-sigma", a->hot_sigma, "hot pixel threshold in robust standard deviations");
    cmd->add_option("--frames", a->frames, "frames per exposure with --capture (at the bracket's shortest and longest)");
    on_run(cmd, [a] {
      const auto rig = load_rig(*a);
      const fs::path out = output_path(*a, rig, calib::kDarkFile, "calibrate dark");
      calib::DarkOptions opt;
      opt.hot_sigma = a->hot_sigma;
      opt.check();
      calib::ExposureStack stack;
      Json devices = Json::object();
      if (a->capture) {
        if (a->frames < 2) throw UsageError("calibrate dark: --frames must be >= 2 (read noise needs repeated frames)");
        const auto& t = rig->plan.exposures_s;
        auto got = capture_stack(*rig, {t.front(), t.back()}, a->frames, false,
                                 rig->calibration_dir / "captures" / "dark");
        stack = std::move(got.stack);
        devices = got.devices;
      } else {
        stack = load_stack_input(a->input);
      }
      const auto frames = stack.frames();
      calib::DarkFrame d = calib::calibrate_dark(frames, stack.bit_depth, opt);
      d.provenance = calib::Provenance::make("dark", stack.files, devices);
      if (out.has_parent_path()) fs::create_directories(out.parent_path());
      d.save(out);
      say(fmt::format("dark: {} frames at {} exposure(s); black level {:.2f} DN, dark current {:.3g} DN/s, read noise {}",
                      d.frame_count, d.exposures_s.size(), d.mean_bias_dn, d.mean_rate_dn_per_s,
                      d.read_noise_measured ? fmt::format("{:.3g} DN", d.read_noise_dn)
                                            : std::string("not measured (needs >= 2 frames at one exposure)")));
      say(fmt::format("  hot pixels: {} ({:.4f} %)", d.hot_count, 100.0 * d.hot_fraction()));
      say("wrote " + out.string() + " and " + fs::path(out).replace_extension(".exr").string());
      return 0;
    });
  }

  // --- flat ----------------------------------------------------------------------------
  {
    struct Args : Common {
      std::string response;
      std::string dark;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = group->add_subcommand(
        "flat", "Flat field (vignetting and pixel gain) from images of a uniform target (writes flat.json + flat.exr)");
    add_common(cmd, a.get(), "flat.json");
    cmd->add_option("--response", a->response, "response.json to linearise with (default with --rig: its response.json)");
    cmd->add_option("--dark", a->dark, "dark.json to subtract (default with --rig: its dark.json)");
    on_run(cmd, [a] {
      const auto rig = load_rig(*a);
      if (a->capture)
        throw UsageError("calibrate flat: --capture is not supported: the camera must look at a uniform target (a "
                         "diffuser over the lens); capture those frames and give --images");
      const fs::path out = output_path(*a, rig, calib::kFlatFile, "calibrate flat");
      fs::path resp_file = a->response, dark_file = a->dark;
      if (rig && resp_file.empty() && fs::exists(rig->calibration_dir / calib::kResponseFile))
        resp_file = rig->calibration_dir / calib::kResponseFile;
      if (rig && dark_file.empty() && fs::exists(rig->calibration_dir / calib::kDarkFile))
        dark_file = rig->calibration_dir / calib::kDarkFile;
      std::optional<calib::ResponseCurve> resp;
      std::optional<calib::DarkFrame> dark;
      if (!resp_file.empty()) resp = calib::ResponseCurve::load(resp_file);
      if (!dark_file.empty()) dark = calib::DarkFrame::load(dark_file);
      const calib::ExposureStack stack = load_stack_input(a->input);
      const auto frames = stack.frames();
      calib::FlatField f = calib::calibrate_flat(frames, stack.bit_depth, {}, resp ? &*resp : nullptr,
                                                 dark ? &*dark : nullptr);
      std::vector<fs::path> inputs = stack.files;
      if (resp) inputs.push_back(resp_file);
      if (dark) inputs.push_back(dark_file);
      f.provenance = calib::Provenance::make("flat", inputs);
      if (out.has_parent_path()) fs::create_directories(out.parent_path());
      f.save(out);
      say(fmt::format("flat: {} frames, mean signal {:.0f} DN; darkest/brightest corner {:.3f}, darkest corner/centre "
                      "{:.3f}, pixel non-uniformity {}",
                      f.frame_count, f.mean_signal_dn, f.corner_ratio, f.centre_to_corner, percent(f.prnu_rel)));
      if (f.noise.known()) say(fmt::format("  conversion gain {:.4g} DN/e ({})", f.noise.gain_dn_per_e, f.noise.source));
      say("wrote " + out.string() + " and " + fs::path(out).replace_extension(".exr").string());
      return 0;
    });
  }
}

}  // namespace paintlab::app
