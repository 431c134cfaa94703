// The session runner's promises, with small in-memory devices whose faults the tests
// switch: every position journaled once with a valid checksum; interruption, device
// faults and crashes leave a consistent journal; resume completes the same session.
// (The same runner over the real drivers and simulated peers is tested in e2e.)
#include <gtest/gtest.h>

#include <csignal>
#include <fmt/format.h>
#include <fstream>
#include <functional>
#include <sys/wait.h>
#include <unistd.h>

#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/core/error.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/hash.h"
#include "fake_rig.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::acq;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

using TestClock = test::FakeClock;
using TestTable = test::FakeTable;
using TestLight = test::FakeLight;
using TestCamera = test::FakeCamera;

ExrImage merge_mean(const std::vector<dev::Frame>& frames) {
  ExrImage img;
  ImageF y(frames[0].pixels.width(), frames[0].pixels.height(), 1);
  for (const auto& f : frames)
    for (std::size_t i = 0; i < y.size(); ++i) y.values()[i] += f.pixels.values()[i] / static_cast<float>(frames.size());
  img.add("Y", y);
  return img;
}

SessionManifest plan(int positions = 7) {
  SessionManifest m;
  m.sample = "blue-01";
  m.rig_name = "test-rig";
  m.rig_file = "/lab/rig.toml";
  for (int i = 0; i < positions; ++i) m.angles_deg.push_back(i * 5.0);
  m.exposures_s = {0.25e-3, 2e-3, 16e-3};
  m.settle_s = 0.5;
  return m;
}

struct RunnerRig {
  TestClock clock;
  TestTable table{clock};
  TestLight light;
  TestCamera camera{clock, light};
  RigHandles handles() { return {table, light, camera, clock}; }
};

// Every position of the plan is finished exactly once, with a valid checksum.
void expect_complete(const SessionDir& s) {
  SessionState st = s.inspect();
  EXPECT_TRUE(st.todo.empty());
  EXPECT_EQ(st.finished_count(), s.position_count());
  for (int i = 0; i < s.position_count(); ++i) {
    ASSERT_TRUE(st.finished[i].has_value()) << i;
    EXPECT_EQ(st.finished[i]->file, SessionDir::hdr_name(i));
    EXPECT_EQ(sha256_file(s.hdr_path(i)), st.finished[i]->sha256);
    EXPECT_DOUBLE_EQ(st.finished[i]->angle_deg, s.manifest().angles_deg[i]);
  }
}

}  // namespace

TEST(Runner, FullSweepJournalsEveryPosition) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan());
  RunnerRig rig;
  std::atomic<bool> stop{false};
  Runner runner(s, rig.handles(), merge_mean);
  RunSummary sum = runner.run(stop);
  EXPECT_TRUE(sum.complete);
  EXPECT_EQ(sum.measured, 7);
  EXPECT_EQ(sum.frames, 21);
  expect_complete(s);
  auto entries = s.journal().read();
  ASSERT_EQ(entries.size(), 7u);
  const JournalEntry& e = entries[3];
  EXPECT_EQ(e.index, 3);
  EXPECT_DOUBLE_EQ(e.angle_read_deg, 15.0);
  ASSERT_EQ(e.exposures_s.size(), 3u);
  EXPECT_NEAR(e.exposures_s[0], 0.25e-3, 1e-12);  // applied value, read back
  EXPECT_EQ(e.frame_ids.size(), 3u);
  EXPECT_TRUE(e.led_was_on);
  EXPECT_TRUE(e.led_off_after);
  EXPECT_FALSE(rig.light.state);
  // The journal line carries the contract fields.
  std::ifstream in(s.dir() / "journal.jsonl");
  std::string line;
  std::getline(in, line);
  Json j = Json::parse(line);
  for (const char* key : {"index", "angle_deg", "file", "sha256"}) EXPECT_TRUE(j.contains(key)) << key;
}

TEST(Runner, SweepTimeIsCloseToThePhysicalMinimum) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(19));
  RunnerRig rig;
  std::atomic<bool> stop{false};
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  ASSERT_TRUE(sum.complete);
  EXPECT_GT(sum.physical_min_s(), 0);
  EXPECT_LE(sum.sweep_s, 1.05 * sum.physical_min_s()) << "sweep " << sum.sweep_s << " s, minimum " << sum.physical_min_s();
  EXPECT_GE(sum.sweep_s, 0.999 * sum.physical_min_s());
}

TEST(Runner, InterruptStopsSafelyAndResumeCompletes) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan());
  std::atomic<bool> stop{false};
  {
    RunnerRig rig;
    rig.camera.on_capture = [&](int n) {
      if (n == 10) stop = true;  // Ctrl-C in the middle of position 3's bracket
    };
    RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
    EXPECT_TRUE(sum.interrupted);
    EXPECT_FALSE(sum.complete);
    EXPECT_FALSE(rig.light.state) << "LED left on";
    EXPECT_GE(rig.table.stops, 1);
    EXPECT_EQ(sum.measured, 3);
    // What `paintlab measure` prints: how far it got and the command that goes on.
    const std::string said = sum.describe(s.dir());
    EXPECT_THAT(said, HasSubstr("positions: 3 of 7 finished (3 in this run, 0 before)\n"));
    EXPECT_THAT(said, HasSubstr("stopped safely (interrupted): the LED is off, the table stopped, 3 positions are "
                                "journaled."));
    EXPECT_THAT(said, HasSubstr("resume with: paintlab measure --resume " + s.dir().string() + "\n"));
    EXPECT_THAT(said, HasSubstr("physical minimum"));
  }
  SessionState st = s.inspect();
  EXPECT_EQ(st.finished_count(), 3);
  EXPECT_EQ(st.todo, (std::vector<int>{3, 4, 5, 6}));
  stop = false;
  RunnerRig rig2;
  RunSummary sum2 = Runner(s, rig2.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum2.complete);
  EXPECT_EQ(sum2.finished_before, 3);
  EXPECT_EQ(sum2.measured, 4);
  expect_complete(s);
  EXPECT_EQ(s.journal().read().size(), 7u) << "no duplicate journal entries";
  const std::string said = sum2.describe(s.dir());
  EXPECT_THAT(said, HasSubstr("positions: 7 of 7 finished (4 in this run, 3 before)\n"));
  EXPECT_THAT(said, HasSubstr("session complete: " + s.dir().string() + "\n"));
  EXPECT_THAT(said, ::testing::Not(HasSubstr("resume with")));
  // Each run left its record in runs.jsonl (what paintlab report draws): the interrupted one,
  // then the one that completed, with the sweep against its physical minimum.
  const std::vector<Json> runs = read_jsonl_file(s.dir() / kRunsFile);
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].at("interrupted"), true);
  EXPECT_EQ(runs[0].at("measured"), 3);
  EXPECT_EQ(runs[1].at("complete"), true);
  EXPECT_EQ(runs[1].at("finished_before"), 3);
  EXPECT_NEAR(runs[1].at("physical_min_s").get<double>(), sum2.physical_min_s(), 1e-9);
  EXPECT_NEAR(runs[1].at("sweep_s").get<double>(), sum2.sweep_s, 1e-9);
  EXPECT_FALSE(runs[1].at("utc_end").get<std::string>().empty());
}

TEST(Runner, RetryableCameraFaultIsRetried) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(3));
  RunnerRig rig;
  rig.camera.lose_frames = 2;
  rig.table.fail_moves = 1;
  std::atomic<bool> stop{false};
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.complete);
  EXPECT_EQ(sum.retries, 3);
  expect_complete(s);
}

TEST(Runner, PersistentFaultStopsSafelyWithAResumableJournal) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(5));
  std::atomic<bool> stop{false};
  {
    RunnerRig rig;
    rig.camera.on_capture = [&](int n) {
      if (n == 7) rig.camera.gone = true;
    };
    RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
    EXPECT_TRUE(sum.device_fault);
    EXPECT_THAT(sum.stop_reason, HasSubstr("camera test"));
    EXPECT_THAT(sum.stop_reason, HasSubstr("camera disappeared"));
    EXPECT_FALSE(rig.light.state);
    EXPECT_EQ(sum.measured, 2);
  }
  {
    RunnerRig rig;
    rig.camera.lose_frames = 100;  // never cured: retries exhausted
    RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
    EXPECT_TRUE(sum.device_fault);
    EXPECT_THAT(sum.stop_reason, HasSubstr("after 3 retries"));
  }
  RunnerRig rig;
  EXPECT_TRUE(Runner(s, rig.handles(), merge_mean).run(stop).complete);
  expect_complete(s);
}

TEST(Runner, StuckLedStopsTheRun) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(3));
  RunnerRig rig;
  rig.light.stuck = true;  // never switches on
  std::atomic<bool> stop{false};
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.device_fault);
  EXPECT_THAT(sum.stop_reason, HasSubstr("did not switch on"));
  EXPECT_EQ(s.inspect().finished_count(), 0);
  RunnerRig rig2;
  rig2.camera.on_capture = [&](int n) {
    if (n == 1) rig2.light.stuck = true;  // stuck on during the bracket
  };
  sum = Runner(s, rig2.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.device_fault);
  EXPECT_THAT(sum.stop_reason, HasSubstr("stuck on"));
}

TEST(Runner, ResumeMeasuresMissingAndCorruptPositionsAgain) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(5));
  std::atomic<bool> stop{false};
  {
    RunnerRig rig;
    ASSERT_TRUE(Runner(s, rig.handles(), merge_mean).run(stop).complete);
  }
  fs::remove(s.hdr_path(1));
  { std::ofstream(s.hdr_path(3), std::ios::app) << "corruption"; }
  SessionState st = s.inspect();
  EXPECT_EQ(st.todo, (std::vector<int>{1, 3}));
  ASSERT_EQ(st.problems.size(), 2u);
  EXPECT_THAT(st.problems[0], HasSubstr("hdr/pos_001.exr: missing"));
  EXPECT_THAT(st.problems[1], HasSubstr("hdr/pos_003.exr: checksum does not match"));
  RunnerRig rig;
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.complete);
  EXPECT_EQ(sum.measured, 2);
  expect_complete(s);
  EXPECT_TRUE(fs::exists(s.dir() / "hdr/rejected/pos_003.exr.1")) << "the corrupt file is kept, not deleted";
}

TEST(Runner, TornJournalAndOrphanFileAreHandled) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(4));
  std::atomic<bool> stop{false};
  {
    RunnerRig rig;
    rig.camera.on_capture = [&](int n) {
      if (n == 6) stop = true;
    };
    Runner(s, rig.handles(), merge_mean).run(stop);
  }
  // A crash after pos 2's file was renamed into place but during its journal append.
  fs::copy_file(s.hdr_path(0), s.hdr_path(2));
  { std::ofstream(s.dir() / "journal.jsonl", std::ios::app) << "{\"index\": 2, \"angle"; }
  stop = false;
  RunnerRig rig;
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.complete);
  expect_complete(s);
  EXPECT_EQ(s.journal().read().size(), 4u);
  EXPECT_TRUE(fs::exists(s.dir() / "journal.jsonl.torn"));
  EXPECT_TRUE(fs::exists(s.dir() / "hdr/rejected/pos_002.exr.1"));
}

TEST(Runner, KilledAtRandomPointsResumesToTheSameSession) {
  // A child process runs the sweep and is SIGKILLed at some point (possibly inside an EXR
  // write or a journal append); the parent resumes until complete.
  test::TempDir d;
  const int positions = 12;
  SessionDir::create(d / "s", plan(positions));
  for (int round = 0; round < 8; ++round) {
    pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      SessionDir s = SessionDir::open(d / "s");
      RunnerRig rig;
      rig.camera.on_capture = [&](int) { usleep(300); };
      std::atomic<bool> stop{false};
      Runner(s, rig.handles(), merge_mean).run(stop);
      _exit(0);
    }
    usleep(2000 + 3000 * round);
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
  }
  SessionDir s = SessionDir::open(d / "s");
  RunnerRig rig;
  std::atomic<bool> stop{false};
  RunSummary sum = Runner(s, rig.handles(), merge_mean).run(stop);
  EXPECT_TRUE(sum.complete);
  expect_complete(s);
  // No duplicates among the valid entries, no torn files left in hdr/.
  for (const auto& entry : fs::directory_iterator(s.dir() / "hdr"))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

TEST(Session, RefusesAFolderHoldingAnotherSession) {
  test::TempDir d;
  SessionDir::create(d / "s", plan());
  std::string before = read_file(d / "s/session.json");
  SessionManifest other = plan();
  other.sample = "red-07";
  try {
    SessionDir::create(d / "s", other);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("already holds a session of sample 'blue-01'"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("paintlab measure --resume"));
  }
  EXPECT_EQ(read_file(d / "s/session.json"), before);
  test::write_text(d / "other/notes.txt", "x");
  EXPECT_THROW(SessionDir::create(d / "other", plan()), DataError);
  SessionManifest empty = plan(0);
  EXPECT_THROW(SessionDir::create(d / "e", empty), DataError);
  EXPECT_THROW(SessionDir::open(d / "nothing"), DataError);
}

TEST(Runner, BadOptionsAreRefusedBeforeAnythingMoves) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan());
  RunnerRig rig;
  auto refused = [&](auto change) {
    RunnerOptions o;
    change(o);
    try {
      Runner runner(s, rig.handles(), merge_mean, o);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(refused([](RunnerOptions& o) { o.max_retries = -1; }), HasSubstr("RunnerOptions::max_retries = -1: allowed 0..100"));
  EXPECT_THAT(refused([](RunnerOptions& o) { o.capture_timeout_s = 0; }), HasSubstr("capture_timeout_s = 0"));
  EXPECT_THAT(refused([](RunnerOptions& o) { o.queue_depth = 0; }), HasSubstr("queue_depth = 0: allowed 1..64"));
  EXPECT_THAT(refused([](RunnerOptions& o) { o.poll_s = std::nan(""); }), HasSubstr("poll_s"));
  EXPECT_EQ(refused([](RunnerOptions&) {}), "accepted");
  EXPECT_EQ(rig.table.moves, 0);
  EXPECT_EQ(rig.camera.captures, 0);
}

namespace {

// A filter wheel in memory: moves at once, or stays where it is once `stuck` (a jammed wheel:
// the move is acknowledged, the position read back is not the one asked for).
class TestWheel final : public dev::FilterWheel {
 public:
  std::string id() const override { return "wheel test"; }
  Result<std::string> identify() override { return std::string("test wheel"); }
  Result<int> slot_count() override { return 6; }
  Result<int> position() override { return slot; }
  Result<void> move_to(int s) override {
    ++moves;
    if (!stuck) slot = s;
    return {};
  }
  int slot = 1;
  int moves = 0;
  bool stuck = false;
};

}  // namespace

TEST(Runner, AFilterWheelTakesOneBracketPerFilterAndTheJournalSaysWhich) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(4));
  RunnerRig rig;
  TestWheel wheel;
  std::atomic<bool> stop{false};
  std::vector<std::vector<int>> filters_seen;
  Runner runner(s, rig.handles(), [&](const std::vector<dev::Frame>& frames) {
    std::vector<int> f;
    for (const auto& fr : frames) f.push_back(fr.meta.filter);
    filters_seen.push_back(f);
    return merge_mean(frames);
  });
  runner.set_filter_wheel(&wheel, {4, 2, 6});
  RunSummary sum = runner.run(stop);
  ASSERT_TRUE(sum.complete) << sum.stop_reason;
  EXPECT_EQ(sum.frames, 4 * 3 * 3);
  // 1 -> 4 -> 2 -> 6, then two moves a position: each starts at the filter the last one ended on.
  EXPECT_EQ(sum.wheel_moves, 3 + 2 + 2 + 2);
  EXPECT_EQ(wheel.moves, 9);
  // R, G, B, then B, G, R: the wheel starts where it stopped.
  ASSERT_EQ(filters_seen.size(), 4u);
  EXPECT_EQ(filters_seen[0], (std::vector<int>{0, 0, 0, 1, 1, 1, 2, 2, 2}));
  EXPECT_EQ(filters_seen[1], (std::vector<int>{2, 2, 2, 1, 1, 1, 0, 0, 0}));
  const auto entries = s.journal().read();
  ASSERT_EQ(entries.size(), 4u);
  EXPECT_EQ(entries[1].filters, (std::vector<std::string>{"B", "B", "B", "G", "G", "G", "R", "R", "R"}));
  EXPECT_EQ(entries[1].filter_slots, (std::vector<int>{6, 6, 6, 2, 2, 2, 4, 4, 4}));
  EXPECT_EQ(entries[1].exposures_s.size(), 9u);
  EXPECT_THAT(sum.describe(s.dir()), HasSubstr("filter wheel"));
  expect_complete(s);
}

TEST(Runner, AWheelThatDoesNotReachItsSlotIsADeviceFaultThatResumes) {
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(4));
  std::atomic<bool> stop{false};
  {
    RunnerRig rig;
    TestWheel wheel;
    Runner runner(s, rig.handles(), merge_mean);
    runner.set_filter_wheel(&wheel, {1, 2, 3});
    rig.camera.on_capture = [&](int n) {
      if (n == 12) wheel.stuck = true;  // jams during the second position
    };
    RunSummary sum = runner.run(stop);
    EXPECT_TRUE(sum.device_fault);
    EXPECT_THAT(sum.stop_reason, HasSubstr("wheel test: the wheel is at slot"));
    EXPECT_THAT(sum.stop_reason, HasSubstr("after 4 attempts"));
    EXPECT_EQ(sum.retries, 3);
    EXPECT_FALSE(rig.light.state);
    EXPECT_EQ(sum.measured, 1);
  }
  RunnerRig rig;
  TestWheel wheel;
  Runner runner(s, rig.handles(), merge_mean);
  runner.set_filter_wheel(&wheel, {1, 2, 3});
  EXPECT_TRUE(runner.run(stop).complete);
  expect_complete(s);
}

TEST(Runner, AFilterWheelAsksThePlannerForEachFiltersBracket) {
  // A planner that keeps one exposure for red, two for green, all three for blue.
  struct PerFilter final : acq::ExposurePlanner {
    std::vector<double> choose(const std::vector<double>& b, const ExrImage*) override { return b; }
    std::vector<double> choose_for_filter(int filter, const std::vector<double>& b, const ExrImage* previous) override {
      if (!previous) return b;
      return std::vector<double>(b.begin(), b.begin() + (filter + 1));
    }
  } planner;
  test::TempDir d;
  SessionDir s = SessionDir::create(d / "s", plan(6));
  RunnerRig rig;
  TestWheel wheel;
  std::atomic<bool> stop{false};
  Runner runner(s, rig.handles(), merge_mean);
  runner.set_filter_wheel(&wheel, {1, 2, 3});
  runner.set_planner(&planner);
  RunSummary sum = runner.run(stop);
  ASSERT_TRUE(sum.complete) << sum.stop_reason;
  // A position planned after an earlier one was stored takes 1 + 2 + 3 frames (3 of 9
  // skipped); the first (and any captured before the writer stored the one before) in full.
  EXPECT_EQ(sum.frames + sum.skipped_frames, 6 * 9);
  EXPECT_GE(sum.skipped_frames, 3);
  EXPECT_EQ(sum.skipped_frames % 3, 0);
  int planned = 0;
  for (const auto& e : s.journal().read()) {
    if (e.filters.size() != 6) continue;
    ++planned;
    EXPECT_TRUE(e.filters == (std::vector<std::string>{"B", "B", "B", "G", "G", "R"}) ||
                e.filters == (std::vector<std::string>{"R", "G", "G", "B", "B", "B"}));
  }
  EXPECT_EQ(planned, sum.skipped_frames / 3);
}
