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

void say(const std::string& line) {
  std::fputs(line.c_str(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

}  // namespace paintlab::app
