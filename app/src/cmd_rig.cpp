// paintlab rig validate FILE
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/core/rig.h"
#include "rig_devices.h"

namespace paintlab::app {

void register_rig_commands(CLI::App& app) {
  CLI::App* rig = subcommand_group(app, "rig", "Rig description (rig.toml)");
  struct ValidateArgs {
    std::string file;
    bool json = false;
  };
  auto [validate, a] = add_command<ValidateArgs>(
      rig, "validate", "Check a rig.toml and print what it describes (or the first error: file, line, key)",
      [](const ValidateArgs& args) {
        // Every key: RigConfig's, the devices' for their kinds, the simulator's [sim].
        const RigConfig r = load_rig(args.file);
        say(args.json ? r.to_json().dump(2) : r.describe());
        return kExitOk;
      });
  validate->add_option("FILE", a->file, "rig.toml to check")->required();
  validate->add_flag("--json", a->json, "Print the parsed rig as JSON");
}

}  // namespace paintlab::app
