#include "paintlab/core/process.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

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

namespace {

// Both ends of a pipe, closed when it goes out of scope.
struct Pipe {
  int fd[2] = {-1, -1};
  Pipe() {
    if (pipe2(fd, O_CLOEXEC) != 0) throw IoError("pipe", "cannot create a pipe for a child process", errno);
  }
  ~Pipe() {
    close_end(0);
    close_end(1);
  }
  Pipe(const Pipe&) = delete;
  Pipe& operator=(const Pipe&) = delete;
  void close_end(int i) {
    if (fd[i] >= 0) ::close(fd[i]);
    fd[i] = -1;
  }
};

int wait_child(pid_t pid, const std::string& exe) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw IoError(exe, "waiting for it", errno);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

}  // namespace

ProcessOutput run_process_capture(const std::string& exe, const std::vector<std::string>& args,
                                  const std::string& input, double timeout_s) {
  Pipe in, out, err;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in.fd[0], 0);
  posix_spawn_file_actions_adddup2(&actions, out.fd[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err.fd[1], 2);
  std::vector<char*> argv{const_cast<char*>(exe.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc == ENOENT) throw IoError(exe, "not found on PATH (is it installed? bash scripts/setup.sh installs it)");
  if (rc != 0) throw IoError(exe, "cannot start it", rc);
  in.close_end(0);
  out.close_end(1);
  err.close_end(1);
  // Our end of the child's input must not block: a blocking write of more than the pipe holds
  // waits for the child to read, while the child waits for us to read its output.
  fcntl(in.fd[1], F_SETFL, fcntl(in.fd[1], F_GETFL) | O_NONBLOCK);
  // A child that exits before reading all its input must not kill us with SIGPIPE.
  struct sigaction ignore {}, old_pipe {};
  sigemptyset(&ignore.sa_mask);
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGPIPE, &ignore, &old_pipe);
  ProcessOutput result;
  std::size_t written = 0;
  if (input.empty()) in.close_end(1);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool timed_out = false;
  char buffer[65536];
  while (out.fd[0] >= 0 || err.fd[0] >= 0) {
    pollfd fds[3];
    int n = 0;
    if (in.fd[1] >= 0) fds[n++] = {in.fd[1], POLLOUT, 0};
    if (out.fd[0] >= 0) fds[n++] = {out.fd[0], POLLIN, 0};
    if (err.fd[0] >= 0) fds[n++] = {err.fd[0], POLLIN, 0};
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    const int ready = poll(fds, static_cast<nfds_t>(n), static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) break;
    for (int i = 0; i < n && ready > 0; ++i) {
      if (fds[i].revents == 0) continue;
      if (fds[i].fd == in.fd[1]) {
        const ssize_t w = ::write(in.fd[1], input.data() + written, input.size() - written);
        if (w > 0) written += static_cast<std::size_t>(w);
        if (w < 0 && errno != EINTR && errno != EAGAIN) in.close_end(1);  // the child closed its input
        if (written == input.size()) in.close_end(1);
        continue;
      }
      const bool is_out = fds[i].fd == out.fd[0];
      const ssize_t r = ::read(fds[i].fd, buffer, sizeof buffer);
      if (r > 0) {
        (is_out ? result.out : result.err).append(buffer, static_cast<std::size_t>(r));
      } else if (r == 0 || (errno != EINTR && errno != EAGAIN)) {
        (is_out ? out : err).close_end(0);
      }
    }
  }
  in.close_end(1);
  if (timed_out) kill(pid, SIGKILL);
  result.exit_code = wait_child(pid, exe);
  sigaction(SIGPIPE, &old_pipe, nullptr);
  if (timed_out) throw IoError(exe, fmt::format("did not finish within {:.0f} s; stopped", timeout_s));
  return result;
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
