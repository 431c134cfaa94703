#include "cli.h"

#include <cstdio>

namespace paintlab::app {
namespace {
std::function<int()> g_chosen;
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

void say(const std::string& line) {
  std::fputs(line.c_str(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

}  // namespace paintlab::app
