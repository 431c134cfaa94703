#include "cli.h"

#include "paintlab/core/text.h"

#include <fmt/format.h>

#include <cstdint>
#include <cstdio>
#include <map>

#include "paintlab/core/error.h"

namespace paintlab::app {
namespace {
std::function<int()> g_chosen;
std::map<std::string, std::string>& flag_of_field() {
  static std::map<std::string, std::string> m;
  return m;
}
}  // namespace

CLI::Option* sets_fields(CLI::Option* option, std::initializer_list<const char*> fields) {
  for (const char* f : fields) flag_of_field()[f] = option->get_name();
  return option;
}

const CLI::Validator& utf8_text() {
  static const CLI::Validator v(
      [](std::string& s) {
        const std::size_t bad = first_invalid_utf8(s);
        if (bad == std::string::npos) return std::string();
        return fmt::format("not valid UTF-8 text (byte {} is 0x{:02x})", bad + 1,
                           static_cast<unsigned>(static_cast<unsigned char>(s[bad])));
      },
      "UTF-8 text", "UTF8");
  return v;
}

std::string option_error_message(const OptionError& e) {
  const auto it = flag_of_field().find(e.field());
  if (it == flag_of_field().end()) return e.what();
  return it->second + " " + e.value() + ": allowed " + e.rule();
}

void on_run(CLI::App* sub, std::function<int()> run) {
  sub->callback([run = std::move(run)] { g_chosen = run; });
}

void add_validate_command(CLI::App* group, const std::string& help, const std::string& file_help,
                          const std::string& json_help, std::string (*describe)(const std::string& file, bool json)) {
  struct ValidateArgs {
    std::string file;
    bool json = false;
  };
  auto [validate, a] = add_command<ValidateArgs>(group, "validate", help, [describe](const ValidateArgs& args) {
    say(describe(args.file, args.json));
    return kExitOk;
  });
  validate->add_option("FILE", a->file, file_help)->required();
  validate->add_flag("--json", a->json, json_help);
}

const std::function<int()>* chosen_command() { return g_chosen ? &g_chosen : nullptr; }

CLI::App* subcommand_group(CLI::App& app, const std::string& name, const std::string& description) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    if (sub->get_name() == name) return sub;
  CLI::App* sub = app.add_subcommand(name, description);
  sub->require_subcommand(1);
  return sub;
}

void check_command_words(const CLI::App& app, int argc, const char* const* argv) {
  const CLI::App* level = &app;
  std::string path = app.get_name();
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word == "--") return;
    if (word.empty() || word.front() == '-') continue;  // an option of the top level (none takes a value)
    const auto subs = level->get_subcommands([](const CLI::App*) { return true; });
    if (subs.empty()) return;  // a command: the rest are its own arguments
    const CLI::App* next = nullptr;
    std::string names;
    for (const CLI::App* s : subs) {
      if (s->check_name(word)) next = s;
      names += (names.empty() ? "" : ", ") + s->get_name();
    }
    if (!next)
      throw UsageError(fmt::format("unknown command '{} {}'; {} has: {} (see {} --help)", path, word,
                                   path == app.get_name() ? "paintlab" : "'" + path + "'", names, path));
    level = next;
    path += " " + word;
  }
}

void say(std::string_view text) {
  while (!text.empty() && text.back() == '\n') text.remove_suffix(1);
  std::fwrite(text.data(), 1, text.size(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

}  // namespace paintlab::app
