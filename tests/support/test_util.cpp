#include "test_util.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sys/wait.h>

namespace fs = std::filesystem;

namespace paintlab::test {

std::uint64_t seed() {
  if (const char* s = std::getenv("PAINTLAB_TEST_SEED")) return std::strtoull(s, nullptr, 10);
  return 20261123;
}

fs::path source_dir() {
  if (const char* s = std::getenv("PAINTLAB_SOURCE_DIR")) return s;
  return PAINTLAB_SOURCE_DIR_DEFAULT;
}

fs::path binary_dir() {
  if (const char* s = std::getenv("PAINTLAB_BINARY_DIR")) return s;
  return PAINTLAB_BINARY_DIR_DEFAULT;
}

fs::path data_dir() {
  if (const char* s = std::getenv("PAINTLAB_DATA_DIR")) return s;
  return source_dir() / "tests/data";
}

TempDir::TempDir() {
  static std::random_device rd;
  fs::path base = fs::temp_directory_path();
  for (int i = 0; i < 100; ++i) {
    fs::path p = base / ("paintlab-test-" + std::to_string(rd()));
    if (fs::create_directory(p)) {
      path_ = p;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary folder");
}

TempDir::~TempDir() {
  if (std::getenv("PAINTLAB_KEEP_TMP")) return;
  std::error_code ec;
  fs::remove_all(path_, ec);
}

void write_text(const fs::path& path, const std::string& text) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << text;
}

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
}  // namespace

RunResult run_paintlab(const std::string& args, int timeout_s) {
  TempDir tmp;
  fs::path exe = binary_dir() / "app" / "paintlab";
  std::string cmd = "timeout " + std::to_string(timeout_s) + " '" + exe.string() + "' " + args + " >'" +
                    (tmp / "out").string() + "' 2>'" + (tmp / "err").string() + "'";
  int status = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(tmp / "out");
  r.err = slurp(tmp / "err");
  return r;
}

}  // namespace paintlab::test
