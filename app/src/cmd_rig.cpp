// paintlab rig validate FILE
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/core/rig.h"
#include "rig_devices.h"

namespace paintlab::app {

void register_rig_commands(CLI::App& app) {
  CLI::App* rig = app.add_subcommand("rig", "Rig description (rig.toml)");
  rig->require_subcommand(1);

  struct ValidateArgs {
    std::string file;
    bool json = false;
  };
  auto args = std::make_shared<ValidateArgs>();
  CLI::App* validate = rig->add_subcommand(
      "validate", "Check a rig.toml and print what it describes (or the first error: file, line, key)");
  validate->add_option("FILE", args->file, "rig.toml to check")->required();
  validate->add_flag("--json", args->json, "Print the parsed rig as JSON");
  on_run(validate, [args] {
    // Every key: RigConfig's, the devices' for their kinds, the simulator's [sim].
    const RigConfig r = load_rig(args->file);
    if (args->json) {
      say(r.to_json().dump(2));
      return 0;
    }
    const auto& g = r.geometry;
    const auto& p = r.plan;
    say(fmt::format("rig '{}' ({}): valid", r.name, r.file.string()));
    say(fmt::format("  calibration folder  {}", r.calibration_dir.string()));
    say(fmt::format("  turntable           {}", r.turntable.kind));
    say(fmt::format("  light               {}", r.light.kind));
    say(fmt::format("  camera              {}", r.camera.kind));
    say(fmt::format("  sphere radius       {:.2f} mm", g.sphere_radius_m * 1e3));
    say(fmt::format("  arm                 radius {:.1f} mm, height {:.1f} mm, zero {:.2f} deg",
                    g.arm_radius_m * 1e3, g.arm_height_m * 1e3, g.arm_zero_deg));
    say(fmt::format("  camera              {:.1f} mm away, {:.1f} mm up, f {:.1f} mm, {}x{} px of {:.2f} um",
                    g.camera_distance_m * 1e3, g.camera_height_m * 1e3, g.focal_length_mm, g.image_width_px,
                    g.image_height_px, g.pixel_size_um));
    auto angles = p.angles_deg();
    say(fmt::format("  light angles        {} positions, {:g} to {:g} deg in {:g} deg steps", angles.size(),
                    p.angle_start_deg, p.angle_stop_deg, p.angle_step_deg));
    say(fmt::format("  exposure bracket    {} exposures, {:.4g} ms to {:.4g} ms", p.exposures_s.size(),
                    p.exposures_s.front() * 1e3, p.exposures_s.back() * 1e3));
    if (r.sim) say("  simulator           [sim] valid");
    return 0;
  });
}

}  // namespace paintlab::app
