// Child processes (core/process.h): the exit code, the signal that ended a child, the pid
// while it runs, and an executable that cannot start.
#include "paintlab/core/process.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

TEST(Process, TheChildsExitCodeComesBack) {
  EXPECT_EQ(run_process("/bin/sh", {"-c", "exit 0"}), 0);
  EXPECT_EQ(run_process("/bin/sh", {"-c", "exit 3"}), 3);
}

TEST(Process, AChildEndedByASignalGives128PlusTheSignal) {
  EXPECT_EQ(run_process("/bin/sh", {"-c", "kill -TERM $$"}), 128 + SIGTERM);
}

TEST(Process, TheRunningPidIsSetWhileTheChildRunsAndClearedAfter) {
  test::TempDir tmp;
  volatile std::sig_atomic_t pid = -1;
  const std::string file = (tmp / "pid").string();
  ASSERT_EQ(run_process("/bin/sh", {"-c", "echo $$ > '" + file + "'"}, &pid), 0);
  EXPECT_EQ(pid, 0);
  std::ifstream in(file);
  long child = 0;
  in >> child;
  EXPECT_GT(child, 0);
}

TEST(Process, AnExecutableThatCannotStartIsNamed) {
  test::TempDir tmp;
  try {
    run_process(tmp / "no-such-program", {});
    FAIL() << "no error";
  } catch (const IoError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no-such-program"));
    EXPECT_THAT(e.what(), HasSubstr("cannot start it"));
  }
}

TEST(Process, ThisProgramsExecutableIsFound) {
  const std::filesystem::path exe = self_executable();
  EXPECT_TRUE(std::filesystem::exists(exe));
  EXPECT_EQ(exe.filename(), "test_core");
}
