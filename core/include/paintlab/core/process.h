#pragma once
// Child processes: `paintlab demo` runs each paintlab command as its own process, as a
// technician types them.
#include <signal.h>

#include <atomic>
#include <csignal>
#include <filesystem>
#include <string>
#include <vector>

namespace paintlab {

// This program's executable (/proc/self/exe). IoError when it cannot be read.
std::filesystem::path self_executable();

// Runs `exe ARGS...` with this process's environment, standard streams and process group
// (Ctrl-C reaches both), waits for it and returns its exit code, or 128 + the signal that
// ended it. IoError naming `exe` when it cannot start.
int run_process(const std::filesystem::path& exe, const std::vector<std::string>& args);

// What a child wrote and how it ended (run_process_capture).
struct ProcessOutput {
  int exit_code = -1;  // or 128 + the signal that ended it
  std::string out;     // its standard output
  std::string err;     // its standard error
};

// Runs `exe ARGS...` (looked up on PATH when it has no slash) with `input` on its standard
// input, collects its standard output and error, and waits for it. A child still running
// after `timeout_s` seconds is killed (IoError naming `exe`). IoError when it cannot start
// (the message says so when it is not installed). Used for helper programs such as gnuplot.
ProcessOutput run_process_capture(const std::string& exe, const std::vector<std::string>& args,
                                  const std::string& input, double timeout_s = 60.0);

// For a program that runs steps as children (paintlab demo): from now on SIGINT is ignored
// here (the child, in the same process group, gets Ctrl-C and stops safely itself) and
// SIGTERM is passed on to the child run_process is waiting for (ignored between children).
void pass_signals_to_children();

// While alive, SIGINT and SIGTERM set requested() instead of ending the process (a
// measurement stops at its next safe point); the handlers before it come back after.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  // The flag the handlers set (false when a StopSignals is made).
  static std::atomic<bool>& requested();

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

}  // namespace paintlab
