// paintlab hdr merge: any exposure stack -> linear radiance EXR with variance and validity
// (channels and weights: docs/radiometry.md).
//   paintlab hdr merge --images FILES... (--exposures LIST | --exposure-file F)
//                      [--response response.json] [--dark dark.json] [--flat flat.json] --out FILE.exr
//   paintlab hdr merge --images ... --rig R --out FILE.exr   (the rig's response/dark/flat that exist)
//   paintlab hdr merge --images BAYER... --cfa RG ...          (a Bayer stack: camera R, G, B)
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>

#include "rig_devices.h"
#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/acquisition/demosaic.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/rig.h"
#include "radiometry_support.h"

namespace fs = std::filesystem;

namespace paintlab::app {

void register_hdr_commands(CLI::App& app) {
  CLI::App* group = subcommand_group(app, "hdr", "High dynamic range images from exposure stacks");
  struct Args {
    StackInput input;
    std::string rig, response, dark, flat, out, weighting, cfa;
    double saturation = -1.0, floor = -1.0, black = -1.0, read_noise = -1.0, gain = -1.0;
    bool half = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = group->add_subcommand(
      "merge", "Merge an exposure stack into linear radiance (EXR: Y or R,G,B, var.*, valid)");
  add_stack_options(cmd, &a->input);
  cmd->add_option("--rig", a->rig, "rig.toml: its calibration folder's response.json, dark.json, flat.json (those that exist)");
  cmd->add_option("--response", a->response, "response.json (default: the rig's, else a linear camera)");
  cmd->add_option("--dark", a->dark, "dark.json: per-pixel dark level and hot pixels");
  cmd->add_option("--flat", a->flat, "flat.json: divide by the flat field");
  cmd->add_option("--out", a->out, "output EXR")->required();
  cmd->add_option("--weighting", a->weighting,
                  "robertson, hat or inverse-variance (default: inverse-variance when a noise model is known)");
  cmd->add_option("--saturation", a->saturation, "raw value treated as saturated (default: the response's or full scale)");
  cmd->add_option("--floor", a->floor, "noise floor in DN above black (default: the response's)");
  cmd->add_option("--black", a->black, "black level in DN without dark frame (default: the response's, else 0)");
  cmd->add_option("--read-noise", a->read_noise, "read noise in DN for the variance (with --gain)");
  cmd->add_option("--gain", a->gain, "conversion gain in DN per electron for the variance (with --read-noise)");
  cmd->add_flag("--half", a->half, "write half floats instead of 32-bit floats");
  cmd->add_option("--cfa", a->cfa,
                  "a Bayer camera's frames (RG, GR, GB or BG, GenICam's names): merge the mosaic, then demosaic the "
                  "radiance to camera R, G, B with its variance");
  on_run(cmd, [a] {
    const fs::path out(a->out);
    if (out.extension() != ".exr") throw UsageError("--out: " + a->out + " is not an .exr file");
    acq::HdrOptions opt;
    if (!a->weighting.empty()) opt.weighting = calib::weighting_from_string(a->weighting, "--weighting");
    opt.saturation_dn = a->saturation;
    opt.floor_dn = a->floor;
    opt.black_dn = a->black;
    if ((a->read_noise >= 0.0) != (a->gain >= 0.0)) throw UsageError("give --read-noise and --gain together");
    if (a->read_noise >= 0.0) opt.noise = {a->read_noise, a->gain, "command line"};
    opt.check();
    // The rig's calibration files, each replaced by the one given explicitly.
    acq::HdrFiles files{a->response, a->dark, a->flat};
    if (!a->rig.empty()) {
      const RigConfig rig = load_rig(a->rig);
      files.complete_from(rig.calibration_dir);
      if (files.empty())
        spdlog::warn("{} has no response.json, dark.json or flat.json: merging as a linear camera",
                     rig.calibration_dir.string());
    }
    {
      OutputSpec out_spec("--out", out);
      out_spec.create_parents = true;
      fit::OutputGuard()
          .inputs("--images", expand_input_files(a->input.images, "--images", kRawImageExtensions))
          .input("--exposure-file", a->input.exposure_file)
          .input("--rig", a->rig)
          .input(a->response.empty() ? "--rig's response" : "--response", files.response)
          .input(a->dark.empty() ? "--rig's dark frame" : "--dark", files.dark)
          .input(a->flat.empty() ? "--rig's flat field" : "--flat", files.flat)
          .output(out_spec)
          .check();
    }
    const acq::HdrCalibration cal = files.load();
    const calib::ExposureStack stack = load_stack_input(a->input);
    const auto frames = stack.frames();
    const auto& first = stack.images.front();
    const auto t0 = std::chrono::steady_clock::now();
    acq::HdrMerger merger(cal, opt, first.width(), first.height(), first.channels(), stack.bit_depth);
    acq::HdrResult r = merger.merge(frames);
    if (!a->cfa.empty()) {
      if (first.channels() != 1) throw UsageError("--cfa: the images have " + std::to_string(first.channels()) + " channels; a Bayer mosaic has one");
      const dev::CfaPattern cfa = dev::cfa_pattern_from_string(a->cfa, "--cfa");
      if (cfa == dev::CfaPattern::None) throw UsageError("--cfa none: give the arrangement (RG, GR, GB or BG)");
      r.image = acq::demosaic_merged(r.image, cfa);
      r.image.attributes["paintlab.cfa"] = a->cfa;
      r.image.attributes["paintlab.colour_space"] = "camera RGB (linear, not colour-calibrated)";
    }
    const double merge_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    files.stamp(r.image);
    if (out.has_parent_path()) fs::create_directories(out.parent_path());
    write_exr(out, r.image, a->half);
    const auto& s = r.stats;
    say(fmt::format("merged {} images {}x{}x{} ({}-bit) in {:.3f} s: {} of {} pixels valid ({} saturated, {} below the "
                    "noise floor, {} hot)",
                    frames.size(), first.width(), first.height(), first.channels(), stack.bit_depth, merge_s, s.valid,
                    s.pixels, s.saturated, s.dark, s.hot));
    say(fmt::format("  weighting {}; variance: {}", s.weighting, s.noise_model));
    say("wrote " + out.string());
    return 0;
  });
}

}  // namespace paintlab::app
