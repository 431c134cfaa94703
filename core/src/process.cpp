#include "paintlab/core/process.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>

#include "paintlab/core/error.h"

extern char** environ;

namespace paintlab {

std::filesystem::path self_executable() {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw IoError("/proc/self/exe", "cannot find this program's executable: " + ec.message());
  return p;
}

namespace {

volatile std::sig_atomic_t g_running_child = 0;
std::atomic<bool> g_stop_requested{false};

extern "C" void pass_term_to_child(int) {
  if (g_running_child > 0) kill(static_cast<pid_t>(g_running_child), SIGTERM);
}

extern "C" void request_stop(int) { g_stop_requested = true; }

}  // namespace

int run_process(const std::filesystem::path& exe, const std::vector<std::string>& args) {
  volatile std::sig_atomic_t* running_pid = &g_running_child;
  const std::string file = exe.string();
  std::vector<char*> argv{const_cast<char*>(file.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (const int rc = posix_spawn(&pid, file.c_str(), nullptr, nullptr, argv.data(), environ); rc != 0)
    throw IoError(file, "cannot start it", rc);
  if (running_pid) *running_pid = pid;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      const int err = errno;
      if (running_pid) *running_pid = 0;
      throw IoError(file, "waiting for it", err);
    }
  }
  if (running_pid) *running_pid = 0;
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

void pass_signals_to_children() {
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_handler = SIG_IGN;
  sigaction(SIGINT, &sa, nullptr);
  sa.sa_handler = pass_term_to_child;
  sigaction(SIGTERM, &sa, nullptr);
}

StopSignals::StopSignals() {
  g_stop_requested = false;
  struct sigaction sa {};
  sa.sa_handler = request_stop;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int_);
  sigaction(SIGTERM, &sa, &old_term_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
}

std::atomic<bool>& StopSignals::requested() { return g_stop_requested; }

}  // namespace paintlab
