// Issue 13 "Data loss": an output that is one of the inputs, or lies inside a session or a
// library the command reads, is refused before any work (exit 2, the message names the flag
// and both paths) and the inputs stay byte for byte as they were. The checker itself is
// tested in tests/unit/core/output_path_test.cpp; these are the probes of the issue, run
// through the paintlab binary.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <map>

#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/json.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// SHA-256 of every file under `dir` (or of `dir` itself when it is a file), by path.
std::map<std::string, std::string> guard_hashes(const fs::path& dir) {
  std::map<std::string, std::string> h;
  if (fs::is_regular_file(dir)) {
    h[dir.string()] = sha256_file(dir);
    return h;
  }
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) h[e.path().string()] = sha256_file(e.path());
  return h;
}

std::unique_ptr<test_support::SimSession> guard_small_sim() {
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.step_deg = 45.0;
  o.sparkle = false;
  return test_support::make_sim_session(
      sim::sim_paint(brdf::load_paint_file(test::source_dir() / "paints/solid-blue.toml")), o);
}

TEST(OutputGuardCli, FitBinAndExportNeverWriteIntoTheSessionTheyRead) {
  const auto sim = guard_small_sim();
  ASSERT_GE(sim->frames.size(), 4u);
  const fs::path s = sim->dir / "S";
  test_support::write_session_folder(*sim, s, "guarded");
  const std::string calib = " --calib " + sim->calibration_dir().string();
  const auto before = guard_hashes(s);
  const std::string inside = " is inside the session folder " + s.string() +
                             " (a measurement session is only written by `paintlab measure`)";

  auto r = test::run_paintlab("fit " + s.string() + calib + " --out " + (s / "session.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--out " + (s / "session.json").string() + inside));

  r = test::run_paintlab("bin " + s.string() + calib + " --out " + (s / "journal.jsonl").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--out " + (s / "journal.jsonl").string() + inside));

  r = test::run_paintlab("export " + s.string() + calib + " --merl " + (s / "hdr" / "pos_003.exr").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--merl " + (s / "hdr" / "pos_003.exr").string() + inside));

  // bin's coverage map, written beside --out, is checked too.
  r = test::run_paintlab("bin " + s.string() + calib + " --out " + (sim->dir / "t.binary").string() + " --coverage " +
                         (s / "hdr" / "pos_001.exr").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--coverage " + (s / "hdr" / "pos_001.exr").string() + inside));
  EXPECT_FALSE(fs::exists(sim->dir / "t.binary"));

  // The session is byte for byte what it was.
  EXPECT_EQ(guard_hashes(s), before);
}

TEST(OutputGuardCli, AMissingOutputFolderIsFoundBeforeTheFit) {
  const auto sim = guard_small_sim();
  const fs::path s = sim->dir / "S";
  test_support::write_session_folder(*sim, s, "guarded");
  const std::string calib = " --calib " + sim->calibration_dir().string();
  const fs::path missing = sim->dir / "no-such-folder";
  const auto t0 = std::chrono::steady_clock::now();
  auto r = test::run_paintlab("fit " + s.string() + calib + " --out " + (missing / "fit.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--out " + (missing / "fit.json").string() + ": the folder " + missing.string() +
                               " does not exist"));
  r = test::run_paintlab("export " + s.string() + calib + " --axf " + (missing / "p.axf.h5").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--axf " + (missing / "p.axf.h5").string() + ": the folder " + missing.string()));
  // Neither binned nor fitted first (a fit of this session takes seconds).
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_FALSE(fs::exists(missing));
}

TEST(OutputGuardCli, RenderAndExportNeverWriteOverTheirInput) {
  test::TempDir tmp;
  const fs::path x = tmp / "X.axf.h5";
  auto r = test::run_paintlab("export " + (test::source_dir() / "paints/silver-metallic.toml").string() + " --axf " +
                              x.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // A fit.json as export reads it (the paint as JSON, with the measured table it was fitted to).
  const fs::path fit = tmp / "fit.json";
  const fs::path table = tmp / "measured.binary";
  write_file_atomic(table, "a measured table");
  Json j = brdf::to_json(brdf::load_paint_file(test::source_dir() / "paints/silver-metallic.toml"));
  j["input"] = {{"kind", "merl"}, {"path", table.string()}};
  write_json_file(fit, j);
  const auto before = guard_hashes(tmp.path());

  r = test::run_paintlab("render " + x.string() + " --out " + x.string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--out " + x.string() + " is the input " + x.string()));

  r = test::run_paintlab("export " + fit.string() + " --axf " + fit.string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--axf " + fit.string() + " is the input " + fit.string()));

  // --merl over the table the fit was made from.
  r = test::run_paintlab("export " + fit.string() + " --merl " + table.string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--merl " + table.string() + " is the input " + table.string() + " (what " +
                               fit.string() + " was fitted to)"));

  // The same file through a symlink or a hard link.
  const fs::path dir = tmp / "links";
  fs::create_directory(dir);
  fs::create_symlink(x, dir / "soft.axf.h5");
  fs::create_hard_link(x, dir / "hard.png");
  for (const char* name : {"soft.axf.h5", "hard.png"}) {
    r = test::run_paintlab("render " + x.string() + " --out " + (dir / name).string());
    EXPECT_EQ(r.exit_code, 2) << name << r.out << r.err;
    EXPECT_THAT(r.err, HasSubstr("--out " + (dir / name).string() + " is the same file as the input " + x.string()));
  }
  r = test::run_paintlab("render " + x.string() + " --out " + (tmp / "preview.png").string() + " --hdr " +
                         (dir / "soft.axf.h5").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--hdr " + (dir / "soft.axf.h5").string()));
  EXPECT_FALSE(fs::exists(tmp / "preview.png"));

  std::map<std::string, std::string> after = guard_hashes(tmp.path());
  for (const char* name : {"soft.axf.h5", "hard.png"}) after.erase((dir / name).string());
  EXPECT_EQ(after, before);
  EXPECT_EQ(sha256_file(dir / "hard.png"), sha256_file(x));
}

TEST(OutputGuardCli, LibraryExportNeverWritesIntoTheLibrary) {
  test::TempDir tmp;
  const fs::path lib = tmp / "L";
  auto r = test::run_paintlab("library add --dir " + lib.string() + " " +
                              (test::source_dir() / "paints/silver-metallic.toml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto before = guard_hashes(lib);
  const std::string inside = " is inside the paint library " + lib.string();

  r = test::run_paintlab("library export --dir " + lib.string() + " --h5 " + (lib / "index.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--h5 " + (lib / "index.json").string() + inside));

  r = test::run_paintlab("library export --dir " + lib.string() + " --folder " + (lib / "copies").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--folder " + (lib / "copies").string() + inside));

  r = test::run_paintlab("library export --dir " + lib.string() + " --folder " + lib.string() + " --overwrite");
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--folder " + lib.string() + " is the paint library " + lib.string()));

  // A library never goes inside another one.
  r = test::run_paintlab("library add --dir " + (lib / "nested").string() + " " +
                         (test::source_dir() / "paints/solid-blue.toml").string());
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("--dir " + (lib / "nested").string() + inside));

  EXPECT_EQ(guard_hashes(lib), before);
  r = test::run_paintlab("library list --dir " + lib.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("1 paint in"));
  // Its own library it still changes, and exports go beside it.
  r = test::run_paintlab("library add --dir " + lib.string() + " " +
                         (test::source_dir() / "paints/solid-blue.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = test::run_paintlab("library export --dir " + lib.string() + " --h5 " + (tmp / "all.h5").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace paintlab::fit
