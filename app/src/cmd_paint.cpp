// paintlab paint validate FILE [--json]
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/brdf/paint.h"

namespace paintlab::app {

void register_paint_commands(CLI::App& app) {
  add_validate_command(
      subcommand_group(app, "paint", "Paint files (TOML): check what they describe"),
      "Check a paint file and print its parameters (or the first error: file, line, key)", "paint .toml to check",
      "Print the parsed paint as JSON (the summary.json \"truth\" shape)", [](const std::string& file, bool json) {
        const brdf::PaintSpec spec = brdf::load_paint_file(file);
        if (json) return brdf::to_json(spec).dump(2);
        const std::string text = brdf::describe_paint(spec);  // its own title line is left out
        return fmt::format("paint '{}' ({}): valid\n  model                 {}\n{}", spec.name, file, spec.model(),
                           text.substr(text.find('\n') + 1));
      });
}

}  // namespace paintlab::app
