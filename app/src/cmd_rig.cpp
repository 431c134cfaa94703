// paintlab rig validate FILE [--json]
#include "cli.h"
#include "paintlab/core/rig.h"
#include "rig_devices.h"

namespace paintlab::app {

void register_rig_commands(CLI::App& app) {
  add_validate_command(subcommand_group(app, "rig", "Rig description (rig.toml)"),
                       "Check a rig.toml and print what it describes (or the first error: file, line, key)",
                       "rig.toml to check", "Print the parsed rig as JSON", [](const std::string& file, bool json) {
                         // Every key: RigConfig's, the devices' for their kinds, the simulator's [sim].
                         const RigConfig r = load_rig(file);
                         return json ? r.to_json().dump(2) : r.describe();
                       });
}

}  // namespace paintlab::app
