// Child processes (core/process.h): the exit code, the signal that ended a child, the pid
// while it runs, and an executable that cannot start.
#include "paintlab/core/process.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

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

TEST(Process, ATerminationIsPassedOnToTheRunningChild) {
  struct sigaction before {};
  sigaction(SIGTERM, nullptr, &before);
  pass_signals_to_children();
  std::thread terminator([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(getpid(), SIGTERM);  // to this process: its handler passes it to the child
  });
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = run_process("/bin/sleep", {"20"});
  terminator.join();
  EXPECT_EQ(rc, 128 + SIGTERM);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(10));
  kill(getpid(), SIGTERM);  // no child: ignored, this test goes on
  struct sigaction sa {};
  sigaction(SIGINT, nullptr, &sa);
  EXPECT_EQ(sa.sa_handler, SIG_IGN);
  sigaction(SIGTERM, &before, nullptr);
  sa.sa_handler = SIG_DFL;
  sigaction(SIGINT, &sa, nullptr);
}

TEST(Process, StopSignalsSetTheFlagWhileAliveAndRestoreTheHandlersAfter) {
  struct sigaction before {};
  sigaction(SIGINT, nullptr, &before);
  {
    StopSignals stop;
    EXPECT_FALSE(StopSignals::requested());
    raise(SIGINT);
    EXPECT_TRUE(StopSignals::requested());
  }
  struct sigaction after {};
  sigaction(SIGINT, nullptr, &after);
  EXPECT_EQ(after.sa_handler, before.sa_handler);
  StopSignals again;  // a new one starts unrequested
  EXPECT_FALSE(StopSignals::requested());
}

TEST(Process, AnExecutableThatCannotStartIsNamed) {
  test::TempDir tmp;
  EXPECT_THAT(test::error_message<IoError>([&] { run_process(tmp / "no-such-program", {}); }),
              ::testing::AllOf(HasSubstr("no-such-program"), HasSubstr("cannot start it")));
}

TEST(Process, ThisProgramsExecutableIsFound) {
  const std::filesystem::path exe = self_executable();
  EXPECT_TRUE(std::filesystem::exists(exe));
  EXPECT_EQ(exe.filename(), "test_core");
}

TEST(Process, ACapturedChildGetsItsInputAndGivesBackItsOutputAndErrors) {
  // More than a pipe's buffer each way: writing and reading must interleave.
  std::string big(300000, 'x');
  const ProcessOutput r = run_process_capture("sh", {"-c", "cat; echo done >&2; exit 3"}, big, 30.0);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.out.size(), big.size());
  EXPECT_EQ(r.err, "done\n");
  EXPECT_THAT(test::error_message<IoError>([] { run_process_capture("paintlab-no-such-program", {}, ""); }),
              HasSubstr("not found on PATH"));
  EXPECT_THAT(test::error_message<IoError>([] { run_process_capture("sleep", {"10"}, "", 0.3); }),
              HasSubstr("did not finish within"));
}
