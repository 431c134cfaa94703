// paintlab devices [--rig R] [--discover] [--all-usb]: what this machine can reach
// (devices/probe.h). Exit 0 when every configured real device answers, 1 otherwise.
#include "cli.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/probe.h"
#include "rig_devices.h"

namespace paintlab::app {

void register_devices_commands(CLI::App& app) {
  struct Args {
    std::string rig;
    dev::ProbeOptions probe;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "devices",
      "List what this machine reaches: the rig's camera (by its address), USB cameras and USB-serial adapters, "
      "gpiochips, the rig's Modbus turntable and its serial filter wheel");
  cmd->add_option("--rig", args->rig, "rig.toml whose devices to probe");
  cmd->add_flag("--discover", args->probe.discover, "Also run Aravis' discovery (broadcasts on every interface)");
  cmd->add_flag("--all-usb", args->probe.all_usb, "List every USB device, not only cameras and serial adapters");
  on_run(cmd, [args] {
    std::optional<RigConfig> rig;
    if (!args->rig.empty()) rig = load_rig(args->rig);
    int missing = 0;
    for (const dev::ProbeLine& line : dev::probe_devices(rig ? &*rig : nullptr, args->probe)) {
      say(line.text);
      missing += line.missing ? 1 : 0;
    }
    return missing == 0 ? kExitOk : kExitFailed;
  });
}

}  // namespace paintlab::app
