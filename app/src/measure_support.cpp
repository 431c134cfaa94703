#include "measure_support.h"

#include <fmt/format.h>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/builtin.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "cli.h"

namespace fs = std::filesystem;

namespace paintlab::app {

Json load_sim_paint_json(const std::string& paint_file) {
  brdf::PaintSpec spec =
      paint_file.empty() ? sim::builtin_paint() : brdf::load_paint_file(paint_file);
  if (spec.merl()) throw UsageError("--sim-paint: a MERL table cannot be simulated with sparkle; use an analytic paint");
  return brdf::to_json(spec);
}

void apply_sim_paint(RigDevices& devices, const Json& paint_json, const fs::path& where) {
  brdf::PaintSpec spec = brdf::paint_from_json(paint_json, (where / "session.json").string() + ": options.sim_paint");
  devices.sim->world().set_paint(sim::sim_paint(spec));
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
