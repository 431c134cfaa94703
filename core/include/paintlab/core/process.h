#pragma once
// Child processes: `paintlab demo` runs each paintlab command as its own process, as a
// technician types them.
#include <csignal>
#include <filesystem>
#include <string>
#include <vector>

namespace paintlab {

// This program's executable (/proc/self/exe). IoError when it cannot be read.
std::filesystem::path self_executable();

// Runs `exe ARGS...` with this process's environment, standard streams and process group
// (Ctrl-C reaches both), waits for it and returns its exit code, or 128 + the signal that
// ended it. While it runs, `*running_pid` (when given) holds its pid, for a signal handler
// to forward a termination to; 0 afterwards. IoError naming `exe` when it cannot start.
int run_process(const std::filesystem::path& exe, const std::vector<std::string>& args,
                volatile std::sig_atomic_t* running_pid = nullptr);

}  // namespace paintlab
