#pragma once
// Logging through spdlog to stderr. Verbosity: -1 quiet (warnings and errors only),
// 0 normal (info), 1 verbose (debug), 2 trace.
#include <spdlog/spdlog.h>

namespace paintlab {

void init_logging(int verbosity);
int log_verbosity();

}  // namespace paintlab
