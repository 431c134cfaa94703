#include "measure_support.h"

#include <cmath>
#include <fmt/format.h>

#include "paintlab/brdf/paint.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "cli.h"
#include "resources.h"

namespace fs = std::filesystem;

namespace paintlab::app {

MeasureSetup prepare_measurement(const RigConfig& rig, bool uncalibrated, bool need_sphere_mask) {
  MeasureSetup s;
  const fs::path dir = rig.calibration_dir;
  auto use = [&](const char* name, const char* step, bool required) -> std::optional<fs::path> {
    fs::path p = dir / name;
    if (!fs::exists(p)) {
      if (required)
        throw DataError(fmt::format("{} is missing: run `paintlab calibrate {} --rig {}` first (or measure with "
                                    "--uncalibrated)",
                                    p.string(), step, rig.file.string()));
      return std::nullopt;
    }
    s.calibration_checksums[name] = sha256_file(p);
    return p;
  };
  if (auto p = use(calib::kResponseFile, "response", !uncalibrated)) s.hdr.response = calib::ResponseCurve::load(*p);
  if (auto p = use(calib::kDarkFile, "dark", !uncalibrated)) s.hdr.dark = calib::DarkFrame::load(*p);
  if (auto p = use(calib::kFlatFile, "flat", false)) s.hdr.flat = calib::FlatField::load(*p);
  // Geometry files are not used by the merge, but the session records which ones were
  // current, so the fit can tell whether they changed after the measurement.
  for (const char* name : {calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile})
    use(name, "", false);
  if (need_sphere_mask) {
    calib::RigCalibration cal = calib::RigCalibration::load(dir);
    cal.require({calib::kCameraFile, calib::kSphereFile});  // --adaptive needs the sphere's outline
    const calib::CameraModel& cam = cal.camera();
    Image<std::uint8_t> mask(cam.width_px, cam.height_px, 1, 0);
    for (int y = 0; y < mask.height(); ++y)
      for (int x = 0; x < mask.width(); ++x) mask.at(x, y) = cal.sphere_point_at(Vec2(x, y)).has_value() ? 1 : 0;
    s.sphere_mask = std::move(mask);
  }
  return s;
}

CameraPreparation prepare_camera(dev::Camera& camera, const RigConfig& rig) {
  CameraPreparation c;
  c.format = value_or_throw(camera.pixel_format());
  c.gain_db = value_or_throw(camera.set_gain_db(rig.plan.gain_db));
  c.range = value_or_throw(camera.exposure_range());
  for (double t : rig.plan.exposures_s) {
    if (t < c.range.min_s * (1 - 1e-9) || t > c.range.max_s * (1 + 1e-9))
      throw DataError(fmt::format("{}: exposure {:.6g} ms of the plan is outside the camera's range [{:.6g}, {:.6g}] ms "
                                  "({}); nothing was written",
                                  rig.file.string(), t * 1e3, c.range.min_s * 1e3, c.range.max_s * 1e3, camera.id()));
  }
  return c;
}

Json load_sim_paint_json(const std::string& paint_file) {
  brdf::PaintSpec spec =
      paint_file.empty()
          ? brdf::parse_paint(ConfigTable::parse_string(resources::paint_silver_metallic_toml(), "silver-metallic.toml"))
          : brdf::load_paint_file(paint_file);
  if (spec.merl()) throw UsageError("--sim-paint: a MERL table cannot be simulated with sparkle; use an analytic paint");
  return brdf::to_json(spec);
}

void apply_sim_paint(RigDevices& devices, const Json& paint_json, const fs::path& where) {
  brdf::PaintSpec spec = brdf::paint_from_json(paint_json, (where / "session.json").string() + ": options.sim_paint");
  devices.sim->world().set_paint(sim::sim_paint(spec));
}

MergeState::MergeState(acq::HdrCalibration calibration, int bit_depth)
    : calibration_(std::move(calibration)), bit_depth_(bit_depth) {}

acq::MergeFn MergeState::function() {
  return [this](const std::vector<dev::Frame>& frames) {
    if (frames.empty()) throw DataError("an empty bracket cannot be merged");
    std::vector<calib::StackFrame> stack;
    stack.reserve(frames.size());
    for (const auto& f : frames) stack.push_back({&f.pixels, f.meta.exposure_s});
    {
      std::lock_guard lock(mutex_);
      if (!merger_) {
        const auto& p = frames.front().pixels;
        merger_ = std::make_unique<acq::HdrMerger>(calibration_, acq::HdrOptions{}, p.width(), p.height(), p.channels(),
                                                   bit_depth_);
      }
    }
    acq::HdrResult r = merger_->merge(stack);
    r.image.attributes["paintlab.valid_pixels"] = std::to_string(r.stats.valid);
    r.image.attributes["paintlab.saturated_pixels"] = std::to_string(r.stats.saturated);
    return std::move(r.image);
  };
}

std::unique_ptr<acq::AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const RigConfig& rig,
                                                                const CameraPreparation& camera) {
  acq::AdaptiveOptions o;
  const double full_scale = std::ldexp(1.0, dev::bit_depth(camera.format)) - 1.0;
  if (setup.hdr.response) {
    const calib::ResponseCurve& g = *setup.hdr.response;
    o.linear_floor = g.to_linear(0, g.window.floor_dn);
    o.linear_saturation = g.to_linear(0, g.window.u_saturation());
    if (g.noise.known()) {
      o.read_noise_dn = g.noise.read_noise_dn;
      o.gain_dn_per_e = g.noise.gain_dn_per_e;
    }
  } else {
    o.linear_floor = 0.0;
    o.linear_saturation = full_scale;
  }
  if (!(o.linear_floor >= 0)) o.linear_floor = 0.0;
  (void)rig;
  return std::make_unique<acq::AdaptiveBracketing>(o, setup.sphere_mask.value_or(Image<std::uint8_t>()));
}

void print_run_summary(const acq::RunSummary& s, const acq::SessionDir& session) {
  const int finished = s.finished_before + s.measured;
  say(fmt::format("positions: {} of {} finished ({} in this run, {} before)", finished, s.positions, s.measured,
                  s.finished_before));
  for (const auto& f : s.resume_findings) say("resume: " + f);
  if (s.frames > 0) {
    const double minimum = s.physical_min_s();
    say(fmt::format("sweep time on the rig clock: {:.1f} s; physical minimum {:.1f} s (motion {:.1f} + settle {:.1f} + "
                    "exposure {:.1f} + readout {:.1f}); ratio {:.3f}",
                    s.sweep_s, minimum, s.motion_s, s.settle_s, s.exposure_s, s.readout_s,
                    minimum > 0 ? s.sweep_s / minimum : 0.0));
    say(fmt::format("frames: {}, retries: {}, wall time {:.1f} s", s.frames, s.retries, s.wall_s));
  }
  if (s.skipped_frames > 0)
    say(fmt::format("adaptive bracketing skipped {} frames, saving {:.1f} s", s.skipped_frames, s.skipped_s));
  if (s.complete) {
    say("session complete: " + session.dir().string());
    return;
  }
  std::string why = s.interrupted ? "interrupted" : s.stop_reason;
  say(fmt::format("stopped safely ({}): the LED is off, the table stopped, {} positions are journaled.", why, finished));
  say("resume with: paintlab measure --resume " + session.dir().string());
}

}  // namespace paintlab::app
