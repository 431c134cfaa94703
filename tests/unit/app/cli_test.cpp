// The command line as a technician and a lab script see it: output, messages, exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "paintlab/core/version.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

TEST(Cli, VersionAndHelp) {
  auto r = test::run_paintlab("--version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("paintlab " + software_version()));
  r = test::run_paintlab("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("Exit codes: 0 success, 1 the job failed"));
  EXPECT_THAT(r.out, HasSubstr("rig"));
}

TEST(Cli, BadUsageExitsTwo) {
  auto r = test::run_paintlab("");
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("no-such-command");
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("rig validate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("FILE is required"));
}

// Issue 13: an unknown command said "A subcommand is required"; -v -q passed silently.
TEST(Cli, AMistypedCommandIsNamedWithWhatExists) {
  auto r = test::run_paintlab("calibrat all --rig x.toml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("unknown command 'paintlab calibrat'; paintlab has: "));
  EXPECT_THAT(r.err, HasSubstr("calibrate"));
  r = test::run_paintlab("-q rig valdate x.toml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("unknown command 'paintlab rig valdate'; 'paintlab rig' has: validate"));
  r = test::run_paintlab("-v -q rig validate " + (test::source_dir() / "examples/rig-sim.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("excludes"));
}

TEST(Cli, RigValidatePrintsTheRig) {
  auto r = test::run_paintlab("rig validate " + (test::source_dir() / "examples/rig-sim.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("rig 'sim-rig'"));
  EXPECT_THAT(r.out, HasSubstr("181 positions, 0 to 180 deg in 1 deg steps"));
  EXPECT_THAT(r.out, HasSubstr("16 exposures, 0.25 ms to 328 ms"));
  r = test::run_paintlab("rig validate --json " + (test::source_dir() / "examples/rig-lab.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"kind\": \"modbus-tcp\""));
}

TEST(Cli, RigValidateNamesTheProblem) {
  test::TempDir d;
  test::write_text(d / "rig.toml", "name = \"x\"\n[devices.turntable]\nkind = \"sim\"\n[devices.light]\nkind = \"sim\"\n"
                                   "[devices.camera]\nkind = \"sim\"\n[geometry]\nsphere_radius_m = 0.04\n"
                                   "arm_radius_m = \"far\"\ncamera_distance_m = 1\n[plan]\nexposures_ms = [1]\n");
  auto r = test::run_paintlab("rig validate " + (d / "rig.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("rig.toml:10: key 'geometry.arm_radius_m': expected a number, got a string"));
  r = test::run_paintlab("rig validate " + (d / "missing.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("missing.toml: no such file"));
}

// Issue 13: `rig validate` passed a [sim] table that `sim render` refused. One validation
// (app's load_rig) serves every command, so each of these exits 2 naming file, line, key.
TEST(Cli, RigValidateChecksTheSimulatorTable) {
  test::TempDir d;
  const std::string base =
      "name = \"x\"\n[devices.turntable]\nkind = \"sim\"\n[devices.light]\nkind = \"sim\"\n"
      "[devices.camera]\nkind = \"sim\"\n[geometry]\nsphere_radius_m = 0.04\narm_radius_m = 0.6\n"
      "camera_distance_m = 1.2\n[plan]\nexposures_ms = [1]\n";
  struct Probe {
    const char* sim;
    const char* message;
  };
  const Probe probes[] = {
      {"[sim]\nseeed = 1\n", "rig.toml:15: key 'sim.seeed': unknown key in [sim]"},
      {"[sim.extra]\nx = 1\n", "key 'sim.extra': unknown key in [sim]"},
      {"[sim.sensor]\nqe = -5\n", "rig.toml:15: key 'sim.sensor.qe': must be in (0, 1] (got -5)"},
      {"[sim.sensor]\nfull_well_e = nan\n", "rig.toml:15: key 'sim.sensor.full_well_e': must be in [100, 1e+07] (got nan)"},
  };
  for (const auto& p : probes) {
    test::write_text(d / "rig.toml", base + p.sim);
    const auto r = test::run_paintlab("rig validate " + (d / "rig.toml").string());
    EXPECT_EQ(r.exit_code, 2) << p.sim;
    EXPECT_THAT(r.err, HasSubstr(p.message)) << p.sim;
  }
  test::write_text(d / "rig.toml", base + "[sim]\nseed = 7\n[sim.sensor]\nqe = 0.5\n");
  const auto r = test::run_paintlab("rig validate " + (d / "rig.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("simulator           [sim] valid"));
}

// Issue 13: a full disk said "bad input" (exit 2). A file-size limit stands in for a full
// disk without root or a mount (ulimit -f with SIGXFSZ ignored: write() fails with EFBIG,
// as it fails with ENOSPC on a full disk): the job fails (exit 1), the message gives the
// system's reason, and no file or temporary is left behind.
TEST(Cli, AFullDiskIsAFailedJobWithTheSystemsReason) {
  test::TempDir d;
  const std::string exe = (test::binary_dir() / "app" / "paintlab").string();
  const std::string cmd = "sh -c \"trap '' XFSZ; ulimit -f 2; exec '" + exe + "' render '" +
                          (test::source_dir() / "paints/solid-blue.toml").string() + "' --out '" +
                          (d / "blue.png").string() + "' --size 256\" 2>'" + (d / "err").string() + "'";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  std::ifstream in(d / "err");
  const std::string err((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(err, HasSubstr((d / "blue.png").string()));
  EXPECT_THAT(err, HasSubstr("File too large"));
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(d.path()))
    if (e.path().filename() != "err") left.push_back(e.path().filename().string());
  EXPECT_TRUE(left.empty()) << left.front();
}

// Issue 13: `axf validate DIR` exited 1 ("no such file", as an invalid file) while a missing
// file exits 2; a folder as a paint or rig file named a missing key.
TEST(Cli, AFolderWhereAFileBelongsIsBadInput) {
  test::TempDir d;
  std::filesystem::create_directory(d / "lib");
  for (const std::string cmd : {"axf validate ", "paint validate ", "rig validate "}) {
    const auto r = test::run_paintlab(cmd + (d / "lib").string());
    EXPECT_EQ(r.exit_code, 2) << cmd;
    EXPECT_THAT(r.err, HasSubstr((d / "lib").string() + ": is a folder, not a file")) << cmd;
  }
}

// Issue 13: option errors named internal structs ("CtFitOptions::lobes = 9",
// "PreviewOptions::size_px") instead of the flag the user typed.
TEST(Cli, AnOptionOutOfRangeIsNamedByItsFlag) {
  test::TempDir d;
  const std::string paint = (test::source_dir() / "paints/solid-blue.toml").string();
  auto r = test::run_paintlab("render " + paint + " --out " + (d / "x.png").string() + " --size 5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("paintlab: error: --size 5: allowed 16..8192"));
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("PreviewOptions")));
  r = test::run_paintlab("render " + paint + " --out " + (d / "x.png").string() + " --light-elevation 95");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--light-elevation 95: allowed [-89, 89]"));
  test::write_text(d / "t.binary", std::string(34992012, '\0'));
  r = test::run_paintlab("fit " + (d / "t.binary").string() + " --lobes 9 --out " + (d / "f.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("paintlab: error: --lobes 9: allowed 1..3"));
  EXPECT_FALSE(std::filesystem::exists(d / "f.json"));
  EXPECT_FALSE(std::filesystem::exists(d / "x.png"));
}

// Issue 13: an invalid UTF-8 --name surfaced as an HDF5 attribute error after the work.
TEST(Cli, FreeTextFlagsMustBeUtf8) {
  test::TempDir d;
  test::write_text(d / "t.binary", std::string(34992012, '\0'));
  for (const char* name : {"blue\xff", "caf\xc3", "\xc0\xaf", "\xed\xa0\x80"}) {  // bad byte, cut short, overlong, surrogate
    const auto r = test::run_paintlab("fit " + (d / "t.binary").string() + " --name '" + name + "' --out " +
                                      (d / "f.json").string());
    EXPECT_EQ(r.exit_code, 2) << name;
    EXPECT_THAT(r.err, HasSubstr("--name")) << name;
    EXPECT_THAT(r.err, HasSubstr("not valid UTF-8 text")) << name;
  }
  const auto r = test::run_paintlab("measure --sample 'panel\xfe' --out " + (d / "s").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("not valid UTF-8 text (byte 6 is 0xfe)"));
  EXPECT_FALSE(std::filesystem::exists(d / "f.json"));
  EXPECT_FALSE(std::filesystem::exists(d / "s"));
}
