#include "paintlab/core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace paintlab {
namespace {
int g_verbosity = 0;
}

void init_logging(int verbosity) {
  g_verbosity = verbosity;
  auto logger = spdlog::get("paintlab");
  if (!logger) logger = spdlog::stderr_color_mt("paintlab");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%^%l%$: %v");
  spdlog::level::level_enum level = spdlog::level::info;
  if (verbosity < 0) level = spdlog::level::warn;
  else if (verbosity == 1) level = spdlog::level::debug;
  else if (verbosity >= 2) level = spdlog::level::trace;
  spdlog::set_level(level);
}

int log_verbosity() { return g_verbosity; }

}  // namespace paintlab
