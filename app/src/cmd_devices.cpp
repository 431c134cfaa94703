// paintlab devices [--rig R] [--discover] [--all-usb]: what this machine can reach.
// Cameras are probed at the rig's address (no broadcast unless --discover), then USB
// devices (USB3 Vision cameras, USB-serial adapters), gpiochips, and the rig's Modbus
// turntable. Exit 0 when every configured real device answers, 1 otherwise.
#include <fmt/format.h>

#include "rig_devices.h"
#include "cli.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/devices/gpiod_light.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/devices/usb_discovery.h"

namespace paintlab::app {

void register_devices_commands(CLI::App& app) {
  struct Args {
    std::string rig;
    bool discover = false;
    bool all_usb = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "devices",
      "List what this machine reaches: the rig's camera (by its address), USB cameras and USB-serial adapters, "
      "gpiochips, and the rig's Modbus turntable");
  cmd->add_option("--rig", args->rig, "rig.toml whose devices to probe");
  cmd->add_flag("--discover", args->discover, "Also run Aravis' discovery (broadcasts on every interface)");
  cmd->add_flag("--all-usb", args->all_usb, "List every USB device, not only cameras and serial adapters");
  on_run(cmd, [args] {
    int missing = 0;
    std::optional<RigConfig> rig;
    if (!args->rig.empty()) {
      rig = load_rig(args->rig);
    }

    // Cameras.
    if (rig && rig->camera.kind == "aravis") {
      auto cfg = dev::camera_config(rig->camera, rig->geometry);
      auto p = dev::probe_aravis_camera(cfg.id);
      if (p)
        say(fmt::format("camera  aravis {}: {} {}, serial {}, id {}", cfg.id, p->vendor, p->model, p->serial,
                        p->device_id));
      else {
        say(fmt::format("camera  aravis {}: not reachable ({})", cfg.id, p.error().what()));
        ++missing;
      }
    } else if (rig) {
      say("camera  sim: simulated (GigE Vision on 127.0.0.1 while `paintlab sim serve` or a measurement runs)");
    }
    if (args->discover) {
      auto found = dev::discover_aravis_cameras();
      if (found.empty()) say("camera  discovery: none found");
      for (const auto& c : found)
        say(fmt::format("camera  discovered {} {} {}, serial {}, address {}", c.device_id, c.vendor, c.model, c.serial,
                        c.address));
    }

    // USB.
    auto usb = dev::list_usb_devices(args->all_usb);
    if (usb.empty()) say("usb     no USB3 Vision camera or USB-serial adapter found");
    for (const auto& u : usb)
      say(fmt::format("usb     {} {} bus {} address {}: {}", dev::to_string(u.kind), u.vid_pid(), u.bus, u.address,
                      u.description));

    // GPIO.
    auto chips = dev::list_gpiochips();
    if (chips.empty()) say("gpio    no gpiochip found");
    for (const auto& c : chips) say(fmt::format("gpio    {} '{}', {} lines", c.name, c.label, c.lines));
    if (rig && rig->light.kind == "gpiod") {
      auto l = dev::gpiod_config(rig->light);
      bool found = false;
      for (const auto& c : chips) found = found || c.name == l.chip || c.label == l.chip || "/dev/" + c.name == l.chip;
      say(fmt::format("light   gpiod {} line {}: {}", l.chip, l.line, found ? "chip present" : "chip not found"));
      if (!found) ++missing;
    } else if (rig) {
      say("light   sim: simulated");
    }

    // Modbus turntable.
    if (rig && rig->turntable.kind != "sim") {
      auto cfg = dev::turntable_config(rig->turntable);
      cfg.retries = 0;
      dev::ModbusTurntable table(cfg);
      auto st = table.status();
      if (st)
        say(fmt::format("table   {}: reachable, at {:.3f} deg, {}{}{}", table.id(), st->angle_deg,
                        st->moving ? "moving" : "still", st->in_position ? ", in position" : "",
                        st->alarm_code ? fmt::format(", alarm {}", st->alarm_code) : std::string()));
      else {
        say(fmt::format("table   {}: not reachable ({})", table.id(), st.error().what()));
        ++missing;
      }
    } else if (rig) {
      say("table   sim: simulated (Modbus on 127.0.0.1 while `paintlab sim serve` or a measurement runs)");
    }
    return missing == 0 ? 0 : 1;
  });
}

}  // namespace paintlab::app
