// paintlab paint validate FILE
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/brdf/paint.h"

namespace paintlab::app {

void register_paint_commands(CLI::App& app) {
  CLI::App* paint = subcommand_group(app, "paint", "Paint files (TOML): check what they describe");
  paint->require_subcommand(1);

  struct ValidateArgs {
    std::string file;
    bool json = false;
  };
  auto args = std::make_shared<ValidateArgs>();
  CLI::App* validate = paint->add_subcommand(
      "validate", "Check a paint file and print its parameters (or the first error: file, line, key)");
  validate->add_option("FILE", args->file, "paint .toml to check")->required();
  validate->add_flag("--json", args->json, "Print the parsed paint as JSON (the summary.json \"truth\" shape)");
  on_run(validate, [args] {
    const brdf::PaintSpec spec = brdf::load_paint_file(args->file);
    if (args->json) {
      say(brdf::to_json(spec).dump(2));
      return 0;
    }
    say(fmt::format("paint '{}' ({}): valid", spec.name, args->file));
    std::string text = brdf::describe_paint(spec);
    // describe_paint() starts with its own title line; keep the parameter lines.
    text = text.substr(text.find('\n') + 1);
    while (!text.empty() && text.back() == '\n') text.pop_back();
    say(fmt::format("  model                 {}", spec.model()));
    say(text);
    return 0;
  });
}

}  // namespace paintlab::app
