// `paintlab measure` on the simulated rig, as a technician runs it: the real drivers talk
// Modbus TCP and GigE Vision to the simulated peers on 127.0.0.1. A sweep writes the
// session; Ctrl-C and kill -9 at random points leave a session that resumes to the same
// result; bad input is refused without touching anything.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <fstream>
#include <random>
#include <set>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include "paintlab/acquisition/session.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

// A paintlab process started in the background.
struct Child {
  pid_t pid = -1;
  fs::path out, err;

  static Child start(const std::vector<std::string>& args, const fs::path& log_dir, const std::string& tag) {
    Child c;
    c.out = log_dir / (tag + ".out");
    c.err = log_dir / (tag + ".err");
    std::string exe = (test::binary_dir() / "app" / "paintlab").string();
    c.pid = fork();
    if (c.pid == 0) {
      int o = ::open(c.out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      int e = ::open(c.err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(o, 1);
      dup2(e, 2);
      std::vector<char*> argv{const_cast<char*>(exe.c_str())};
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    return c;
  }
  // Waits up to timeout_s; returns the exit code, or -signal when killed, or -1000 on timeout.
  int wait(double timeout_s) {
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    while (std::chrono::steady_clock::now() < deadline) {
      pid_t r = waitpid(pid, &status, WNOHANG);
      if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    return -1000;
  }
  std::string stdout_text() const { return read_file(out); }
  std::string stderr_text() const { return read_file(err); }
};

int journal_lines(const fs::path& session) {
  if (!fs::exists(session / "journal.jsonl")) return 0;
  std::ifstream in(session / "journal.jsonl");
  int n = 0;
  std::string line;
  while (std::getline(in, line)) n += !line.empty();
  return n;
}

// Waits until the session's journal has at least n lines (or the child ended).
bool wait_for_journal(Child& c, const fs::path& session, int n, double timeout_s) {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (journal_lines(session) >= n) return true;
    int status;
    if (waitpid(c.pid, &status, WNOHANG) == c.pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

// Mean of the merged radiance over the brightest quarter of the image (the lit sphere).
double lit_mean(const fs::path& exr) {
  ExrImage img = read_exr(exr);
  std::vector<float> v = img.plane("Y").values();
  std::sort(v.begin(), v.end());
  double s = 0;
  std::size_t from = v.size() * 3 / 4;
  for (std::size_t i = from; i < v.size(); ++i) s += v[i];
  return s / static_cast<double>(v.size() - from);
}

// The session is complete: one journal line per position, each file's checksum matches,
// no temporary or torn files.
void expect_complete_session(const fs::path& dir, int positions) {
  acq::SessionDir s = acq::SessionDir::open(dir);
  acq::SessionState st = s.inspect();
  EXPECT_TRUE(st.todo.empty()) << st.todo.size() << " positions missing";
  EXPECT_TRUE(st.problems.empty()) << (st.problems.empty() ? "" : st.problems.front());
  EXPECT_EQ(st.finished_count(), positions);
  std::set<int> seen;
  for (const auto& e : s.journal().read()) EXPECT_TRUE(seen.insert(e.index).second) << "index " << e.index << " twice";
  EXPECT_EQ(static_cast<int>(seen.size()), positions);
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

class MeasureCli : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = dir_ / "rig.toml";
    test::write_text(rig_, test::small_sim_rig(kPositions, 10.0, 4));
  }
  static constexpr int kPositions = 5;
  test::TempDir dir_;
  fs::path rig_;
};

}  // namespace

TEST_F(MeasureCli, SweepWritesTheSessionAndJournal) {
  fs::path out = dir_ / "session";
  auto r = test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample blue-07 --notes 'first try' --out " +
                              out.string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("positions: 5 of 5 finished"));
  EXPECT_THAT(r.out, HasSubstr("session complete"));
  expect_complete_session(out, kPositions);
  Json session = read_json_file(out / "session.json");
  EXPECT_EQ(session["sample"], "blue-07");
  EXPECT_EQ(session["notes"], "first try");
  EXPECT_EQ(session["rig"]["sha256"], sha256_file(rig_));
  EXPECT_EQ(session["plan"]["angles_deg"].size(), 5u);
  EXPECT_FALSE(session["devices"]["camera"]["serial"].get<std::string>().empty());
  for (const auto& e : acq::SessionDir::open(out).journal().read()) {
    EXPECT_NEAR(e.angle_read_deg, e.angle_deg, 0.02);
    EXPECT_EQ(e.exposures_s.size(), 4u);
    EXPECT_TRUE(e.led_was_on && e.led_off_after);
  }
  // The sweep's time on the rig clock against the physical minimum (motion + settle +
  // exposure + readout).
  auto pos = r.out.find("ratio ");
  ASSERT_NE(pos, std::string::npos);
  double ratio = std::stod(r.out.substr(pos + 6));
  EXPECT_LE(ratio, 1.05);
  EXPECT_GE(ratio, 0.999);
}

TEST_F(MeasureCli, CtrlCStopsSafelyAndResumeCompletes) {
  fs::path out = dir_ / "session";
  const int positions = 40;  // long enough that Ctrl-C arrives mid-sweep
  fs::path rig = dir_ / "long.toml";
  test::write_text(rig, test::small_sim_rig(positions, 2.0, 4));
  Child c = Child::start({"measure", "--uncalibrated", "--rig", rig.string(), "--sample", "s", "--out", out.string()},
                         dir_.path(), "run1");
  ASSERT_TRUE(wait_for_journal(c, out, 2, 120)) << c.stderr_text();
  kill(c.pid, SIGINT);
  int code = c.wait(60);
  EXPECT_EQ(code, 1) << c.stdout_text() << c.stderr_text();
  EXPECT_THAT(c.stdout_text(), HasSubstr("stopped safely (interrupted)"));
  EXPECT_THAT(c.stdout_text(), HasSubstr("resume with: paintlab measure --resume " + fs::absolute(out).string()));
  int done = journal_lines(out);
  EXPECT_GE(done, 2);
  EXPECT_LT(done, positions);
  auto r = test::run_paintlab("measure --resume " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr(fmt::format("({} in this run, {} before)", positions - done, done)));
  expect_complete_session(out, positions);
}

TEST_F(MeasureCli, KilledAtRandomPointsResumesToTheSameSession) {
  fs::path ref = dir_ / "reference";
  ASSERT_EQ(test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample s --out " + ref.string()).exit_code, 0);
  fs::path out = dir_ / "session";
  std::mt19937 rng(static_cast<unsigned>(test::seed()));
  std::uniform_int_distribution<int> delay_ms(50, 2500);
  Child first = Child::start({"measure", "--uncalibrated", "--rig", rig_.string(), "--sample", "s", "--out", out.string()},
                             dir_.path(), "kill0");
  std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
  kill(first.pid, SIGKILL);
  first.wait(10);
  for (int round = 1; round <= 4 && fs::exists(out / "session.json"); ++round) {
    Child c = Child::start({"measure", "--resume", out.string()}, dir_.path(), "kill" + std::to_string(round));
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    kill(c.pid, SIGKILL);
    c.wait(10);
  }
  if (!fs::exists(out / "session.json")) {
    // Killed before the session was created: nothing was written, start again.
    ASSERT_FALSE(fs::exists(out) && !fs::is_empty(out));
    ASSERT_EQ(test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample s --out " + out.string()).exit_code, 0);
  }
  auto r = test::run_paintlab("measure --resume " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  expect_complete_session(out, kPositions);
  // Same positions and, within the noise, the same images as the uninterrupted run.
  for (int i = 0; i < kPositions; ++i) {
    fs::path a = ref / acq::SessionDir::hdr_name(i), b = out / acq::SessionDir::hdr_name(i);
    EXPECT_NEAR(lit_mean(b), lit_mean(a), 0.02 * lit_mean(a)) << "position " << i;
  }
}

TEST_F(MeasureCli, RefusesAFolderHoldingAnotherSample) {
  fs::path out = dir_ / "session";
  ASSERT_EQ(test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample red-01 --out " + out.string()).exit_code, 0);
  std::string journal = read_file(out / "journal.jsonl");
  auto r = test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample blue-02 --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("already holds a session of sample 'red-01'"));
  EXPECT_EQ(read_file(out / "journal.jsonl"), journal) << "nothing overwritten";
}

TEST_F(MeasureCli, RefusesExposuresOutsideTheCameraRange) {
  fs::path rig = dir_ / "long.toml";
  std::string text = test::small_sim_rig(3, 10.0, 4);
  text.replace(text.find("max_ms = 200"), 12, "max_ms = 900000");
  test::write_text(rig, text);
  fs::path out = dir_ / "session";
  auto r = test::run_paintlab("measure --uncalibrated --rig " + rig.string() + " --sample s --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("outside the camera's range"));
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(MeasureCli, RefusesAPlanWithoutAngles) {
  fs::path rig = dir_ / "noangles.toml";
  std::string text = test::small_sim_rig(3, 10.0, 4);
  text.replace(text.find("angle_stop_deg = 20"), 19, "angle_stop_deg = -10");
  test::write_text(rig, text);
  auto r = test::run_paintlab("measure --uncalibrated --rig " + rig.string() + " --sample s --out " + (dir_ / "x").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("key 'plan.angle_stop_deg': must not be smaller than angle_start_deg"));
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

TEST_F(MeasureCli, MissingCalibrationSaysWhichStepToRun) {
  auto r = test::run_paintlab("measure --rig " + rig_.string() + " --sample s --out " + (dir_ / "x").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("response.json is missing: run `paintlab calibrate response"));
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

// A monochrome camera behind the simulated filter wheel (kind sim: a pty pair behind the real
// serial driver): every position takes a bracket per filter, the journal says which, and the
// stored R, G, B are the paint seen through each filter.
TEST_F(MeasureCli, AFilterWheelMeasuresOneBracketPerFilter) {
  test::write_text(rig_, test::small_sim_rig(kPositions, 10.0, 4) +
                             "[devices.filter_wheel]\nkind = \"sim\"\nslot_r = 2\nslot_g = 4\nslot_b = 6\n");
  // The dark frame and the response (through whichever filter the wheel holds: they are the
  // sensor's), so that the camera RGB is linear and dark-subtracted; --uncalibrated: no colour
  // calibration, camera RGB as recorded.
  for (const char* step : {"dark", "response"}) {
    auto c = test::run_paintlab(std::string("calibrate ") + step + " --rig " + rig_.string() + " --capture", 120);
    ASSERT_EQ(c.exit_code, 0) << c.out << c.err;
  }
  const fs::path out = dir_ / "session";
  // Nothing to demosaic behind a wheel: --demosaic is refused, naming itself, before anything is written.
  auto r = test::run_paintlab("measure --uncalibrated --demosaic gradient-corrected --rig " + rig_.string() +
                              " --sample blue --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--demosaic applies to a colour-filter-array camera"));
  EXPECT_FALSE(fs::exists(out / "session.json"));
  r = test::run_paintlab("measure --uncalibrated --rig " + rig_.string() + " --sample blue --out " + out.string() +
                         " --sim-paint " + (test::source_dir() / "paints/solid-blue.toml").string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("filter wheel"));
  expect_complete_session(out, kPositions);
  const Json options = read_json_file(out / "session.json")["options"];
  EXPECT_EQ(options["colour_space"], "linear camera RGB");
  EXPECT_EQ(options["demosaic"], "none (filter wheel)");
  const auto entries = acq::SessionDir::open(out).journal().read();
  ASSERT_EQ(entries.size(), static_cast<std::size_t>(kPositions));
  EXPECT_EQ(entries[0].filters, (std::vector<std::string>{"R", "R", "R", "R", "G", "G", "G", "G", "B", "B", "B", "B"}));
  EXPECT_EQ(entries[0].filter_slots, (std::vector<int>{2, 2, 2, 2, 4, 4, 4, 4, 6, 6, 6, 6}));
  EXPECT_EQ(entries[1].filters.front(), "B");  // the wheel goes back the way it came
  // On the sphere's lit side (blue above a third of its 99th percentile: the felt and the
  // backdrop are grey and darker), the channel ratios are the blue paint's diffuse colour (kd
  // 0.03, 0.06, 0.30) as the sensor (its weights 0.2126, 0.7152, 0.0722 of scene R, G, B) sees
  // it through each default filter ([sim.filters]).
  const double kd[3] = {0.03, 0.06, 0.30}, weight[3] = {0.2126, 0.7152, 0.0722};
  const double filter[3][3] = {{0.92, 0.05, 0.01}, {0.04, 0.90, 0.06}, {0.01, 0.06, 0.88}};
  double seen[3] = {0, 0, 0};
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) seen[c] += weight[k] * filter[c][k] * kd[k];
  const ExrImage img = read_exr(out / "hdr/pos_002.exr");
  EXPECT_EQ(img.find("Y"), nullptr);
  const std::vector<float>& b = img.plane("B").values();
  std::vector<float> sorted = b;
  std::sort(sorted.begin(), sorted.end());
  const float threshold = sorted[sorted.size() * 99 / 100] / 3;
  std::vector<double> br, gr;
  for (std::size_t i = 0; i < b.size(); ++i)
    if (b[i] > threshold && img.plane("valid").values()[i] > 0.5f) {
      br.push_back(b[i] / img.plane("R").values()[i]);
      gr.push_back(img.plane("G").values()[i] / img.plane("R").values()[i]);
    }
  ASSERT_GT(br.size(), 100u);
  std::nth_element(br.begin(), br.begin() + static_cast<std::ptrdiff_t>(br.size() / 2), br.end());
  std::nth_element(gr.begin(), gr.begin() + static_cast<std::ptrdiff_t>(gr.size() / 2), gr.end());
  std::printf("median B/R %.3f (diffuse %.3f), G/R %.3f (%.3f) over %zu pixels\n", br[br.size() / 2],
              seen[2] / seen[0], gr[gr.size() / 2], seen[1] / seen[0], br.size());
  EXPECT_NEAR(br[br.size() / 2], seen[2] / seen[0], 0.03 * seen[2] / seen[0]);
  EXPECT_NEAR(gr[gr.size() / 2], seen[1] / seen[0], 0.03 * seen[1] / seen[0]);
}
