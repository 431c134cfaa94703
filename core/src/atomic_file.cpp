#include "paintlab/core/atomic_file.h"

#include <atomic>
#include <cerrno>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"

namespace fs = std::filesystem;

namespace paintlab {
namespace {
std::atomic<unsigned> g_counter{0};

void write_all(int fd, const char* data, std::size_t n, const fs::path& path) {
  while (n > 0) {
    ssize_t w = ::write(fd, data, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw IoError(path.string(), "write failed", errno, IoOp::Write);
    }
    data += w;
    n -= static_cast<std::size_t>(w);
  }
}

fs::path parent_or_dot(const fs::path& p) {
  fs::path parent = p.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}
}  // namespace

fs::path temp_path_for(const fs::path& path) {
  unsigned n = g_counter.fetch_add(1);
  return parent_or_dot(path) / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                                std::to_string(n));
}

void fsync_path(const fs::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(path.string(), "cannot open for fsync", errno, IoOp::Write);
  int rc = ::fsync(fd);
  int err = errno;
  ::close(fd);
  if (rc != 0) throw IoError(path.string(), "fsync failed", err, IoOp::Write);
}

void write_via_temp(const fs::path& path, const std::function<void(const fs::path& tmp)>& writer) {
  fs::path tmp = temp_path_for(path);
  try {
    writer(tmp);
    fsync_path(tmp);
    if (::rename(tmp.c_str(), path.c_str()) != 0) throw IoError(path.string(), "cannot rename temporary file into place", errno, IoOp::Write);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  fsync_path(parent_or_dot(path));
}

void write_file_atomic(const fs::path& path, std::string_view bytes) {
  write_via_temp(path, [&](const fs::path& tmp) {
    int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) throw IoError(path.string(), "cannot create file", errno, IoOp::Write);
    try {
      write_all(fd, bytes.data(), bytes.size(), path);
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (::close(fd) != 0) throw IoError(path.string(), "close failed", errno, IoOp::Write);
  });
}

std::string read_file(const fs::path& path) {
  require_readable_file(path);  // a folder, a dangling link or a loop, said as such
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path.string(), "cannot open for reading", errno);
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError(path.string(), "read failed", errno);
  return ss.str();
}

int remove_stale_temps(const fs::path& dir) {
  int removed = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    std::string name = entry.path().filename().string();
    if (name.size() > 1 && name[0] == '.' && name.find(".tmp-") != std::string::npos) {
      if (fs::remove(entry.path(), ec)) ++removed;
    }
  }
  return removed;
}

}  // namespace paintlab
