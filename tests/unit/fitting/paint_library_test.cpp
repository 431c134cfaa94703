// The paint library: add / list / show (load) / remove / export, duplicate names, checksums,
// crashes during add (a child process killed at every step and at random times: the index
// is the old or the new one and every file it names is whole), concurrent writers, and the
// `paintlab library` commands.
#include "paintlab/fitting/paint_library.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <random>
#include <set>
#include <thread>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/core/version.h"
#include "paintlab/fitting/multiangle.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using namespace paintlab::fit;
using ::testing::HasSubstr;

namespace {

AxfPaint make_paint(const std::string& name, double m0 = 0.3, bool fitted = true) {
  AxfPaint p;
  p.name = name;
  p.model = "cook-torrance";
  AxfCookTorrance ct;
  ct.params.kd = brdf::Rgb(0.03, 0.032, 0.035);
  ct.params.lobes = {{brdf::Rgb(0.06, 0.062, 0.066), m0, 0.85}, {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}};
  p.cook_torrance = ct;
  if (fitted) {
    AxfFitQuality q;
    q.log_rms = 0.02 + m0 / 100;
    q.bins_used = 5000;
    q.residual = {{"log_rms", q.log_rms}, {"bins_used", 5000}};
    p.fit_quality = q;
    p.provenance.measured_utc = "2026-11-20T09:15:00Z";
    p.provenance.sample_name = "panel-" + name;
  }
  return p;
}

// waitpid with a deadline: a child that hangs is killed and the test fails (never hangs).
int wait_child(pid_t pid, double timeout_s = 60.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  for (;;) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return status;
    if (r < 0 && errno != EINTR) {
      ADD_FAILURE() << "waitpid(" << pid << ") failed, errno " << errno;
      return -1;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      ADD_FAILURE() << "child " << pid << " did not finish within " << timeout_s << " s";
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

// Runs `body` in a child process; returns the wait status.
int run_child(const std::function<void()>& body) {
  const pid_t pid = fork();
  if (pid == 0) {
    try {
      body();
    } catch (...) {
      _exit(3);
    }
    _exit(0);
  }
  return wait_child(pid);
}

// The library is consistent: the index parses, names are unique, every file it names
// exists, matches its checksum and reads back as the named paint. Only files left by an
// interrupted add may be extra.
void expect_consistent(const PaintLibrary& lib) {
  const auto entries = lib.list();
  for (const auto& e : entries) {
    SCOPED_TRACE(e.name);
    const AxfPaint p = lib.load(e.name);
    EXPECT_EQ(p.name, e.name);
  }
  for (const auto& finding : lib.check()) EXPECT_THAT(finding, HasSubstr("is not in the index")) << finding;
}

std::vector<std::string> names(const std::vector<LibraryEntry>& entries) {
  std::vector<std::string> out;
  for (const auto& e : entries) out.push_back(e.name);
  return out;
}

}  // namespace

TEST(PaintLibrary, AddListLoadRemove) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp / "lib", true);
  EXPECT_TRUE(fs::exists(tmp / "lib/index.json"));
  EXPECT_TRUE(lib.list().empty());
  const AxfPaint silver = make_paint("silver", 0.3);
  const AxfPaint blue = make_paint("blue", 0.2, false);
  const LibraryEntry es = lib.add(silver, false);
  lib.add(blue, false);

  const auto entries = lib.list();
  ASSERT_EQ(names(entries), (std::vector<std::string>{"blue", "silver"}));
  EXPECT_EQ(entries[1], es);
  EXPECT_EQ(es.model, "cook-torrance");
  EXPECT_EQ(es.date, "2026-11-20T09:15:00Z");
  EXPECT_EQ(es.sample, "panel-silver");
  ASSERT_TRUE(es.log_rms);
  EXPECT_DOUBLE_EQ(*es.log_rms, 0.023);
  EXPECT_EQ(es.bins_used, 5000);
  EXPECT_FALSE(entries[0].log_rms);  // not a fit
  EXPECT_GT(parse_utc_timestamp(entries[0].date), 0);  // export time when never measured

  const AxfPaint back = lib.load("silver");
  EXPECT_EQ(*back.cook_torrance, *silver.cook_torrance);
  EXPECT_EQ(*back.fit_quality, *silver.fit_quality);

  // Reopening sees the same index.
  EXPECT_EQ(PaintLibrary::open(tmp / "lib", false).list(), entries);

  lib.remove("silver");
  EXPECT_EQ(names(lib.list()), std::vector<std::string>{"blue"});
  EXPECT_FALSE(fs::exists(tmp / "lib" / es.file));
  EXPECT_THAT(test::error_message<DataError>([&] { lib.remove("silver"); }),
              HasSubstr("no paint 'silver' (paints: blue)"));
  EXPECT_TRUE(lib.check().empty());
}

// A designed paint (model cosine-lobes, /cosine_lobes only) is a library paint like the others:
// its colour at the multi-angle geometries is the cosine-lobe model's.
TEST(PaintLibrary, ACosineLobesPaintIsAddedWithItsColour) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp / "lib", true);
  AxfPaint p;
  p.name = "designed";
  p.model = "cosine-lobes";
  p.colour_space = colour::kLinearSrgb;
  brdf::CosineLobeParams cl;
  cl.exponents = {3, 60, 2000};
  cl.kd = brdf::Rgb(0.3, 0.05, 0.04);
  cl.kg = {brdf::Rgb(0.01, 0.002, 0.002), brdf::Rgb(0.2, 0.05, 0.04), brdf::Rgb(12, 12, 12)};
  cl.kdd = {brdf::Rgb(0.1, 0.02, 0.02), brdf::Rgb(0.3, 0.06, 0.05), brdf::Rgb(0, 0, 0)};
  p.cosine_lobes = cl;
  const LibraryEntry e = lib.add(p, false);
  EXPECT_EQ(e.model, "cosine-lobes");
  const auto expected = colour_at(brdf::CosineLobes(cl), geometry_set(kDefaultGeometrySet));
  ASSERT_EQ(e.colour.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(e.colour[i].first, expected[i].geometry.name);
    EXPECT_NEAR(e.colour[i].second.L, expected[i].lab.L, 1e-9) << i;
    EXPECT_NEAR(e.colour[i].second.a, expected[i].lab.a, 1e-9) << i;
  }
  EXPECT_GT(e.colour.front().second.a, 10.0);  // a red paint
  EXPECT_EQ(lib.load("designed").cosine_lobes, p.cosine_lobes);
}

TEST(PaintLibrary, DuplicateNamesNeedReplace) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
  const LibraryEntry first = lib.add(make_paint("silver", 0.3), false);
  const std::string index_before = read_file(tmp / "index.json");
  EXPECT_THAT(test::error_message<DataError>([&] { lib.add(make_paint("silver", 0.4), false); }),
              ::testing::AllOf(HasSubstr("a paint named 'silver' is already there"), HasSubstr("--replace")));
  EXPECT_EQ(read_file(tmp / "index.json"), index_before);
  EXPECT_TRUE(lib.check().empty());

  const LibraryEntry second = lib.add(make_paint("silver", 0.4), true);
  EXPECT_NE(second.file, first.file);
  EXPECT_FALSE(fs::exists(tmp / first.file));
  ASSERT_EQ(lib.list().size(), 1u);
  EXPECT_DOUBLE_EQ(lib.load("silver").cook_torrance->params.lobes[0].m, 0.4);
  EXPECT_TRUE(lib.check().empty());
}

TEST(PaintLibrary, RefusesFoldersThatAreNotLibraries) {
  test::TempDir tmp;
  EXPECT_THROW(PaintLibrary::open(tmp / "none", false), DataError);
  test::write_text(tmp / "other/notes.txt", "not a library\n");
  EXPECT_THAT(test::error_message<DataError>([&] { PaintLibrary::open(tmp / "other", true); }),
              HasSubstr("not empty"));
  test::write_text(tmp / "broken/index.json", "{\"format\": \"paintlab-library\", \"format_version\": 9, \"paints\": []}");
  EXPECT_THROW(PaintLibrary::open(tmp / "broken", false), DataError);
}

TEST(PaintLibrary, ChangedFilesAreDetected) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
  const LibraryEntry e = lib.add(make_paint("silver"), false);
  const std::string bytes = read_file(tmp / e.file);
  write_file_atomic(tmp / e.file, bytes.substr(0, bytes.size() / 2));
  try {
    lib.load("silver");
    FAIL();
  } catch (const DataError& err) {
    EXPECT_THAT(err.what(), HasSubstr("changed since it was added"));
  }
  ASSERT_EQ(lib.check().size(), 1u);
  EXPECT_THAT(lib.check()[0], HasSubstr("changed since it was added"));
}

TEST(PaintLibrary, ExportAsOneFileOrAFolder) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp / "lib", true);
  lib.add(make_paint("silver", 0.3), false);
  lib.add(make_paint("blue", 0.2, false), false);

  lib.export_h5(tmp / "all.h5");
  const auto all = read_axf_library_file(tmp / "all.h5");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "blue");
  EXPECT_EQ(all[1], lib.load("silver"));

  const auto files = lib.export_folder(tmp / "out", false);
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(read_axf_file(tmp / "out/silver.axf.h5"), lib.load("silver"));
  EXPECT_THROW(lib.export_folder(tmp / "out", false), IoError);
  EXPECT_NO_THROW(lib.export_folder(tmp / "out", true));
}

// A child adding a paint is killed (SIGKILL) at each step of the add; afterwards the
// index is exactly the old one (killed before the index was replaced) or the new one.
TEST(PaintLibrary, CrashAtEveryStepOfAddLeavesOldOrNewIndex) {
  for (bool replace : {false, true}) {
    for (const std::string step : {"locked", "paint-written", "index-written", "old-file-removed"}) {
      if (step == "old-file-removed" && !replace) continue;
      SCOPED_TRACE(step + (replace ? " (replace)" : ""));
      test::TempDir tmp;
      PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
      lib.add(make_paint("blue", 0.2), false);
      lib.add(make_paint("silver", 0.3), false);
      const auto before = lib.list();

      const int status = run_child([&] {
        PaintLibrary child = PaintLibrary::open(tmp.path(), false);
        child.set_step_hook([&](const std::string& s) {
          if (s == step) raise(SIGKILL);
        });
        child.add(make_paint(replace ? "silver" : "red", 0.5), replace);
      });
      ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the child was not killed at " << step;

      const auto after = lib.list();
      const bool index_replaced = step == "index-written" || step == "old-file-removed";
      if (!index_replaced) {
        EXPECT_EQ(after, before);
      } else {
        EXPECT_EQ(after.size(), before.size() + (replace ? 0 : 1));
        const std::string changed = replace ? "silver" : "red";
        EXPECT_DOUBLE_EQ(lib.load(changed).cook_torrance->params.lobes[0].m, 0.5);
      }
      expect_consistent(lib);
      // The library keeps working after the crash.
      lib.add(make_paint("green", 0.25), false);
      expect_consistent(lib);
    }
  }
}

// Killed at random moments while adding one paint after another: every time, the index
// holds a prefix of the sequence and every file it names is whole.
TEST(PaintLibrary, CrashAtRandomTimesDuringAdds) {
  std::mt19937_64 rng(test::seed());
  std::uniform_int_distribution<int> delay_us(0, 400000);
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
  std::vector<std::string> sequence;
  for (int i = 0; i < 40; ++i) sequence.push_back("paint-" + std::to_string(100 + i));
  int killed_mid_run = 0;
  for (int round = 0; round < 6; ++round) {
    SCOPED_TRACE(round);
    const std::size_t have = lib.list().size();
    const pid_t pid = fork();
    if (pid == 0) {
      try {
        PaintLibrary child = PaintLibrary::open(tmp.path(), false);
        for (std::size_t i = have; i < sequence.size(); ++i)
          child.add(make_paint(sequence[i], 0.1 + 0.01 * static_cast<double>(i)), false);
      } catch (...) {
        _exit(3);
      }
      _exit(0);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(delay_us(rng)));
    kill(pid, SIGKILL);
    const int status = wait_child(pid);
    if (WIFSIGNALED(status)) ++killed_mid_run;
    else
      ASSERT_EQ(WEXITSTATUS(status), 0);
    const auto entries = lib.list();
    ASSERT_GE(entries.size(), have);
    // Entries are sorted by name and the sequence is in name order: a prefix.
    for (std::size_t i = 0; i < entries.size(); ++i) EXPECT_EQ(entries[i].name, sequence[i]);
    expect_consistent(lib);
  }
  EXPECT_GT(killed_mid_run, 0);
  EXPECT_GT(lib.list().size(), 0u);  // the children got somewhere between the kills
}

TEST(PaintLibrary, ConcurrentWritersLoseNothing) {
  test::TempDir tmp;
  PaintLibrary::open(tmp.path(), true);
  std::vector<pid_t> pids;
  for (const char* prefix : {"a", "b"}) {
    const pid_t pid = fork();
    if (pid == 0) {
      try {
        PaintLibrary child = PaintLibrary::open(tmp.path(), false);
        for (int i = 0; i < 8; ++i) child.add(make_paint(std::string(prefix) + "-" + std::to_string(i)), false);
      } catch (...) {
        _exit(3);
      }
      _exit(0);
    }
    pids.push_back(pid);
  }
  for (pid_t pid : pids) {
    const int status = wait_child(pid);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  const PaintLibrary lib = PaintLibrary::open(tmp.path(), false);
  EXPECT_EQ(lib.list().size(), 16u);
  expect_consistent(lib);
}

TEST(PaintLibrary, ALockHeldTooLongIsAnErrorNotAHang) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
  // Another holder of the lock (flock locks belong to the open file description, so a
  // second open() in this process conflicts like another process would).
  const int fd = ::open((tmp / ".lock").c_str(), O_RDWR | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  lib.set_lock_timeout(0.3);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    lib.add(make_paint("silver"), false);
    ADD_FAILURE() << "add went ahead while another process held the lock";
  } catch (const IoError& e) {
    EXPECT_THAT(e.what(), HasSubstr(".lock"));
    EXPECT_THAT(e.what(), HasSubstr("held the library lock for 0.3 s"));
  }
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited, 0.3);
  EXPECT_LT(waited, 5.0);
  EXPECT_TRUE(lib.list().empty());
  ::flock(fd, LOCK_UN);
  ::close(fd);
  EXPECT_NO_THROW(lib.add(make_paint("silver"), false));
  EXPECT_EQ(lib.list().size(), 1u);
}

// Issue 16, item 6: the instrument-style sparkle of a paint with measured flakes is in its
// library entry (index version 3); "not measured" stays null, never 0; older indexes still read.
TEST(PaintLibrary, MeasuredSparkleIsStoredWithTheEntry) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp / "lib", true);
  AxfPaint sparkly = make_paint("sparkly");
  FlakeStats fs;
  fs.colour_space = colour::kLinearSrgb;
  fs.images = 10;
  fs.pixels = 4000;
  fs.glints = 120;
  fs.lifetime_deg = 4.5;
  FlakeSlice slice;  // the file keeps the totals as the sum of its slices
  slice.theta_f = 1;
  slice.theta_i = 2;
  slice.pixels = 4000;
  slice.glints = 120;
  slice.intensity_mean = 2.5;
  slice.clusters = {{{60, -5, 3}, {70, 5, 9}, {65, 0, 6}, 1.0, 120}};
  slice.inverse_cdf = {0, 0};
  fs.slices = {slice};
  // 15 deg: 12 glints in 80 samples; 45 deg: measured, no glint; 75 deg: not measured.
  fs.instrument = {{15, 80, 12, 15.0, 2.75}, {45, 200, 0, 0.0, 0.0}, {75, 0, 0, 0.0, 0.0}};
  sparkly.flake_stats = fs;
  const LibraryEntry e = lib.add(sparkly, false);
  lib.add(make_paint("plain"), false);

  ASSERT_TRUE(e.sparkle);
  EXPECT_EQ(e.sparkle->glints, 120u);
  EXPECT_DOUBLE_EQ(e.sparkle->area_percent, 3.0);
  EXPECT_DOUBLE_EQ(e.sparkle->lifetime_deg, 4.5);
  ASSERT_EQ(e.sparkle->at.size(), 3u);
  EXPECT_EQ(e.sparkle->at[0], (LibrarySparkle::At{15, 15.0, 2.75}));
  EXPECT_EQ(e.sparkle->at[1], (LibrarySparkle::At{45, 0.0, std::nullopt}));
  EXPECT_EQ(e.sparkle->at[2], (LibrarySparkle::At{75, std::nullopt, std::nullopt}));
  EXPECT_FALSE(lib.find("plain").sparkle);
  EXPECT_EQ(PaintLibrary::open(tmp / "lib", false).find("sparkly"), e);  // through index.json

  Json j = read_json_file(tmp / "lib/index.json");
  EXPECT_EQ(j["format_version"], 3);
  const Json& js = j["paints"][1]["sparkle"];
  EXPECT_EQ(j["paints"][1]["name"], "sparkly");
  EXPECT_TRUE(js["instrument"][2]["sparkle_area_percent"].is_null());
  EXPECT_TRUE(js["instrument"][1]["sparkle_intensity"].is_null());
  EXPECT_EQ(js["instrument"][1]["sparkle_area_percent"], 0.0);
  EXPECT_TRUE(j["paints"][0]["sparkle"].is_null());

  auto r = test::run_paintlab("library show --dir " + (tmp / "lib").string() + " sparkly");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("sparkle: 120 glints, 3.00 % of the pixel samples, lifetime 4.50 deg"));
  EXPECT_THAT(r.out, HasSubstr("sparkle at 15 deg light, viewed along the normal: area 15.00 %, intensity 2.75"));
  EXPECT_THAT(r.out, HasSubstr("sparkle at 45 deg light, viewed along the normal: area 0.00 %, intensity no glint"));
  EXPECT_THAT(r.out, HasSubstr("sparkle at 75 deg light, viewed along the normal: area not measured"));
  r = test::run_paintlab("library list --dir " + (tmp / "lib").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("SPARKLE AREA % AT 15/45/75"));
  EXPECT_THAT(r.out, HasSubstr("15.00 / 0.00 / n/m"));

  // A version-2 index (no sparkle key) still reads: no sparkle until the paint is added again.
  j["format_version"] = 2;
  for (Json& p : j["paints"]) p.erase("sparkle");
  write_json_file(tmp / "lib/index.json", j);
  EXPECT_FALSE(PaintLibrary::open(tmp / "lib", false).find("sparkly").sparkle);
  // A damaged sparkle entry is named.
  j["format_version"] = 3;
  j["paints"][1]["sparkle"] = {{"area_percent", 3.0}, {"lifetime_deg", 4.5}, {"glints", 120}};
  write_json_file(tmp / "lib/index.json", j);
  EXPECT_THAT(test::error_message<DataError>([&] { PaintLibrary::open(tmp / "lib", false); }),
              HasSubstr("paints[1].sparkle: key 'instrument': expected an array"));
}

TEST(PaintLibraryCli, AddListShowRemoveExport) {
  test::TempDir tmp;
  const std::string dir = " --dir " + (tmp / "lib").string();
  const std::string silver = (test::source_dir() / "paints/silver-metallic.toml").string();
  const std::string blue = (test::source_dir() / "paints/solid-blue.toml").string();
  auto r = test::run_paintlab("library add" + dir + " " + silver);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("added 'silver-metallic'"));
  r = test::run_paintlab("library add" + dir + " " + blue);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_paintlab("library add" + dir + " " + silver);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--replace"));
  r = test::run_paintlab("library add" + dir + " " + silver + " --replace");
  EXPECT_EQ(r.exit_code, 0) << r.err;

  r = test::run_paintlab("library list" + dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("NAME"));
  EXPECT_THAT(r.out, HasSubstr("LOG_RMS"));
  EXPECT_THAT(r.out, HasSubstr("silver-metallic"));
  EXPECT_THAT(r.out, HasSubstr("cook-torrance"));
  EXPECT_THAT(r.out, HasSubstr("2 paints"));
  r = test::run_paintlab("library list --json" + dir);
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_EQ(Json::parse(r.out).size(), 2u);

  r = test::run_paintlab("library show" + dir + " solid-blue");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("kd  [0.03, 0.06, 0.3]"));
  r = test::run_paintlab("library show" + dir + " red");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("no paint 'red'"));

  r = test::run_paintlab("library export" + dir + " --h5 " + (tmp / "all.h5").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_axf_library_file(tmp / "all.h5").size(), 2u);
  r = test::run_paintlab("library export" + dir + " --folder " + (tmp / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(tmp / "out/solid-blue.axf.h5"));
  r = test::run_paintlab("library export" + dir + " --folder " + (tmp / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("library export" + dir);
  EXPECT_EQ(r.exit_code, 2);

  r = test::run_paintlab("library remove" + dir + " solid-blue");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_paintlab("library list" + dir);
  EXPECT_THAT(r.out, HasSubstr("1 paint in"));
  r = test::run_paintlab("library list --dir " + (tmp / "nolib").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("not a paint library"));
}

// Issue 13: a library add that failed while writing the index (a full disk) left its
// NAME.N.axf.h5 behind, one more with each retry. An add is all or nothing, and what a
// killed add leaves (kill -9 cannot clean up) is removed by the next change.
TEST(PaintLibrary, AFailedAddLeavesNothingAndLeftoversGoWithTheNextChange) {
  test::TempDir tmp;
  PaintLibrary lib = PaintLibrary::open(tmp.path(), true);
  const LibraryEntry blue = lib.add(make_paint("blue", 0.2, false), false);
  const auto files = [&] {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(tmp.path()))
      if (e.path().filename().string().front() != '.') out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto files_before = files();
  const std::string index_before = read_file(tmp / "index.json");
  lib.set_step_hook([&](const std::string& step) {
    if (step == "paint-written") throw IoError((tmp / "index.json").string(), "write failed", ENOSPC, IoOp::Write);
  });
  for (int attempt = 0; attempt < 3; ++attempt) {
    try {
      lib.add(make_paint("silver", 0.3), false);
      ADD_FAILURE() << "the add went through";
    } catch (const IoError& e) {
      EXPECT_EQ(exit_code(e), kExitFailed);
      EXPECT_THAT(e.what(), HasSubstr("No space left on device"));
    }
  }
  EXPECT_EQ(files(), files_before);
  EXPECT_EQ(read_file(tmp / "index.json"), index_before);
  EXPECT_TRUE(lib.check().empty());

  lib.set_step_hook({});
  write_file_atomic(tmp / "silver.7.axf.h5", read_file(tmp / blue.file));  // as a killed add leaves it
  test::write_text(tmp / "notes.txt", "the technician's notes\n");         // not a paint file name: kept
  ASSERT_EQ(lib.check().size(), 1u);
  EXPECT_THAT(lib.check()[0], HasSubstr("silver.7.axf.h5 is not in the index"));
  lib.add(make_paint("silver", 0.3), false);
  EXPECT_FALSE(fs::exists(tmp / "silver.7.axf.h5"));
  EXPECT_TRUE(fs::exists(tmp / "notes.txt"));
  EXPECT_TRUE(lib.check().empty());
  EXPECT_EQ(names(lib.list()), (std::vector<std::string>{"blue", "silver"}));
}
