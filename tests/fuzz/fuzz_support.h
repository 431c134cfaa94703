#pragma once
// What every fuzz harness shares. A harness hands the fuzzer's bytes to one parser a user
// can give a file to. The parser may refuse them only with a paintlab::Error (the one-line
// message the command prints, exit 2); any other exception, a signal, a sanitizer report,
// a leak or a hang is a finding and stops the run.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "paintlab/core/error.h"

namespace paintlab::fuzz {

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// A file holding the fuzzer's bytes, for parsers that read a path (EXR, MERL, HDF5). It
// lives in the process's own folder under TMPDIR (or /tmp), so parallel jobs never share it.
class InputFile {
 public:
  explicit InputFile(const char* name) {
    const char* tmp = std::getenv("TMPDIR");
    dir_ = std::filesystem::path(tmp && *tmp ? tmp : "/tmp") / ("paintlab-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    path_ = dir_ / name;
  }
  const std::filesystem::path& write(const std::uint8_t* data, std::size_t size) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    if (!out) std::abort();  // the fuzzer's own folder must be writable
    return path_;
  }
  ~InputFile() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

 private:
  std::filesystem::path dir_, path_;
};

// Runs `parse`; a paintlab::Error is the expected refusal of bad input, anything else
// escapes to libFuzzer (which reports an uncaught exception as a crash with its stack).
template <class F>
void expect_clean(F&& parse) {
  try {
    parse();
  } catch (const Error&) {
  }
}

}  // namespace paintlab::fuzz
