#include "cli.h"

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

namespace {
// The byte offset of the first byte that breaks UTF-8 (RFC 3629: no overlong forms, no
// surrogates, at most U+10FFFF), or npos.
std::size_t first_bad_utf8(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      ++i;
      continue;
    }
    // The lead byte gives the length; 0xc0, 0xc1 and 0xf5.. only start overlong or too large forms.
    const std::size_t n = c >= 0xc2 && c <= 0xdf ? 1 : c >= 0xe0 && c <= 0xef ? 2 : c >= 0xf0 && c <= 0xf4 ? 3 : 0;
    if (n == 0 || i + n >= s.size()) return i;  // not a lead byte, or cut short
    std::uint32_t cp = c & (0x3fu >> n);
    for (std::size_t k = 1; k <= n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0u) != 0x80u) return i;
      cp = (cp << 6) | (d & 0x3fu);
    }
    const std::uint32_t min = n == 1 ? 0x80u : n == 2 ? 0x800u : 0x10000u;
    if (cp < min || cp > 0x10ffffu || (cp >= 0xd800u && cp <= 0xdfffu)) return i;
    i += n + 1;
  }
  return std::string::npos;
}
}  // namespace

const CLI::Validator& utf8_text() {
  static const CLI::Validator v(
      [](std::string& s) {
        const std::size_t bad = first_bad_utf8(s);
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

void say(const std::string& line) {
  std::fputs(line.c_str(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

}  // namespace paintlab::app
