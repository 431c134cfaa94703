#pragma once
// Test helpers: fixed seeds, temporary folders, paths to the source tree and shared data,
// running the paintlab binary, and domain matchers.
#include <gmock/gmock.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

namespace paintlab::test {

// The seed every test uses for its random generators (PAINTLAB_TEST_SEED overrides).
std::uint64_t seed();

// The source tree (PAINTLAB_SOURCE_DIR), the build tree (PAINTLAB_BINARY_DIR) and the
// real data the tests use, carried by the project: tests/data/<set>/ with its SOURCES.md
// (PAINTLAB_DATA_DIR overrides).
std::filesystem::path source_dir();
std::filesystem::path binary_dir();
std::filesystem::path data_dir();

// A fresh empty folder removed when the object dies (kept if PAINTLAB_KEEP_TMP is set).
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// The message of the E that `f` throws, "(no error)" when it throws nothing (an exception of
// another type passes through): EXPECT_THAT(error_message<UsageError>([&] { ... }), HasSubstr(...)).
template <class E, class F>
std::string error_message(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "(no error)";
}

// The [devices] tables of a rig.toml whose turntable, light and camera are all simulated.
inline const std::string kSimDevicesToml =
    "[devices.turntable]\nkind = \"sim\"\n[devices.light]\nkind = \"sim\"\n[devices.camera]\nkind = \"sim\"\n";

// Writes text to a file (creating folders).
void write_text(const std::filesystem::path& path, const std::string& text);

// Runs the paintlab binary with `args` (a shell-quoted string), returns its exit code and
// captures stdout and stderr.
struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};
RunResult run_paintlab(const std::string& args, int timeout_s = 300);

// |a - b| <= tol_rel * |b| (relative tolerance).
MATCHER_P2(NearRel, expected, tol_rel,
           std::string(negation ? "not " : "") + "within " + ::testing::PrintToString(tol_rel * 100) +
               "% of " + ::testing::PrintToString(expected)) {
  return std::abs(arg - expected) <= tol_rel * std::abs(expected);
}

// Angles in degrees equal within tol_deg, modulo 360.
MATCHER_P2(NearAngleDeg, expected_deg, tol_deg,
           std::string(negation ? "not " : "") + "an angle within " + ::testing::PrintToString(tol_deg) +
               " deg of " + ::testing::PrintToString(expected_deg)) {
  double d = std::remainder(static_cast<double>(arg) - expected_deg, 360.0);
  return std::abs(d) <= tol_deg;
}

// An RGB triple (anything indexable [0..2]) within an absolute tolerance per channel.
MATCHER_P2(RgbNear, expected, tol,
           std::string(negation ? "not " : "") + "an RGB within " + ::testing::PrintToString(tol)) {
  for (int c = 0; c < 3; ++c)
    if (!(std::abs(static_cast<double>(arg[c]) - static_cast<double>(expected[c])) <= tol)) return false;
  return true;
}

}  // namespace paintlab::test
