#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
namespace fs = std::filesystem;

TEST(AtomicFile, WritesAndReplaces) {
  test::TempDir d;
  write_file_atomic(d / "a.txt", "old");
  write_file_atomic(d / "a.txt", "new content");
  EXPECT_EQ(read_file(d / "a.txt"), "new content");
  int n = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(d.path())) ++n;
  EXPECT_EQ(n, 1) << "no temporary file left behind";
}

TEST(AtomicFile, FailingWriterLeavesOldFileAndNoTemp) {
  test::TempDir d;
  write_file_atomic(d / "a.txt", "old");
  EXPECT_THROW(write_via_temp(d / "a.txt",
                              [](const fs::path& tmp) {
                                test::write_text(tmp, "half");
                                throw DataError("writer failed");
                              }),
               DataError);
  EXPECT_EQ(read_file(d / "a.txt"), "old");
  int n = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(d.path())) ++n;
  EXPECT_EQ(n, 1);
}

TEST(AtomicFile, CrashMidWriteLeavesOldOrNewNeverTorn) {
  // A child process writes large files in a loop and is killed at some point; the target
  // must always hold one complete version.
  test::TempDir d;
  const std::string a(1 << 20, 'a'), b(1 << 20, 'b');
  write_file_atomic(d / "f", a);
  for (int trial = 0; trial < 5; ++trial) {
    pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      for (int i = 0;; ++i) write_file_atomic(d / "f", i % 2 ? a : b);
    }
    usleep(20000 + trial * 7000);
    kill(pid, SIGKILL);
    int status;
    waitpid(pid, &status, 0);
    std::string content = read_file(d / "f");
    EXPECT_TRUE(content == a || content == b) << "torn file of size " << content.size();
    EXPECT_GE(remove_stale_temps(d.path()), 0);
  }
}

TEST(AtomicFile, MissingFolderIsIoError) {
  EXPECT_THROW(write_file_atomic("/nonexistent-dir/x.txt", "x"), IoError);
  EXPECT_THROW(read_file("/nonexistent-dir/x.txt"), IoError);
}
