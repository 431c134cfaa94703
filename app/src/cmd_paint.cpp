// paintlab paint validate FILE
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/brdf/paint.h"

namespace paintlab::app {

void register_paint_commands(CLI::App& app) {
  CLI::App* paint = subcommand_group(app, "paint", "Paint files (TOML): check what they describe");
  struct ValidateArgs {
    std::string file;
    bool json = false;
  };
  auto [validate, a] = add_command<ValidateArgs>(
      paint, "validate", "Check a paint file and print its parameters (or the first error: file, line, key)",
      [](const ValidateArgs& args) {
        const brdf::PaintSpec spec = brdf::load_paint_file(args.file);
        if (args.json) {
          say(brdf::to_json(spec).dump(2));
          return kExitOk;
        }
        say(fmt::format("paint '{}' ({}): valid", spec.name, args.file));
        say(fmt::format("  model                 {}", spec.model()));
        const std::string text = brdf::describe_paint(spec);
        say(std::string_view(text).substr(text.find('\n') + 1));  // describe_paint's own title line left out
        return kExitOk;
      });
  validate->add_option("FILE", a->file, "paint .toml to check")->required();
  validate->add_flag("--json", a->json, "Print the parsed paint as JSON (the summary.json \"truth\" shape)");
}

}  // namespace paintlab::app
