#pragma once
// Child processes for the protocol tests (peers such as pymodbus, socat, Aravis' fake
// camera): spawned with stdout/stderr on a pipe, read line by line with a timeout, and
// terminated (by their own pid) when the object dies.
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace paintlab::test {

class Process {
 public:
  explicit Process(const std::vector<std::string>& argv) {
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, p[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&fa, p[1], STDERR_FILENO);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int rc = posix_spawnp(&pid_, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    close(p[1]);
    fd_ = p[0];
    if (rc != 0) {
      close(fd_);
      throw std::runtime_error("cannot start " + argv[0]);
    }
  }
  ~Process() { terminate(); }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  // The next output line, or nullopt after timeout_s or at end of output.
  std::optional<std::string> read_line(double timeout_s) {
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      auto nl = buf_.find('\n');
      if (nl != std::string::npos) {
        std::string line = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return line;
      }
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || fd_ < 0) return std::nullopt;
      pollfd pfd{fd_, POLLIN, 0};
      if (poll(&pfd, 1, static_cast<int>(left.count())) <= 0) continue;
      char tmp[1024];
      ssize_t n = read(fd_, tmp, sizeof tmp);
      if (n <= 0) {
        close(fd_);
        fd_ = -1;
        if (!buf_.empty()) {
          std::string rest = buf_;
          buf_.clear();
          return rest;
        }
        return std::nullopt;
      }
      buf_.append(tmp, static_cast<std::size_t>(n));
    }
  }
  // Reads lines until one contains `needle` (returned) or the timeout.
  std::optional<std::string> wait_for(const std::string& needle, double timeout_s, std::string* seen = nullptr) {
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0) return std::nullopt;
      auto line = read_line(left);
      if (!line) return std::nullopt;
      if (seen) *seen += *line + "\n";
      if (line->find(needle) != std::string::npos) return line;
    }
  }
  // Exit status after waiting up to timeout_s (-1 if still running).
  int wait_exit(double timeout_s) {
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (pid_ > 0) {
      int st = 0;
      pid_t r = waitpid(pid_, &st, WNOHANG);
      if (r == pid_) {
        pid_ = -1;
        return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
      }
      if (std::chrono::steady_clock::now() > deadline) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }
  void signal(int sig) {
    if (pid_ > 0) kill(pid_, sig);
  }
  void terminate() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      if (wait_exit(3.0) < 0 && pid_ > 0) {
        kill(pid_, SIGKILL);
        waitpid(pid_, nullptr, 0);
        pid_ = -1;
      }
    }
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string buf_;
};

// A TCP port on 127.0.0.1 that was free a moment ago.
inline int free_tcp_port() {
  int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  close(s);
  return ntohs(a.sin_port);
}

// Whether something accepts TCP connections on 127.0.0.1:port within timeout_s.
inline bool wait_tcp(int port, double timeout_s) {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    int s = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    int rc = connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
    close(s);
    if (rc == 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

// A socat pty pair: two /dev/pts paths connected to each other.
struct PtyPair {
  Process socat{{"socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"}};
  std::string a, b;
  PtyPair() {
    for (std::string* p : {&a, &b}) {
      auto line = socat.wait_for("PTY is ", 5.0);
      if (!line) throw std::runtime_error("socat gave no pty");
      *p = line->substr(line->find("PTY is ") + 7);
    }
  }
};

}  // namespace paintlab::test
