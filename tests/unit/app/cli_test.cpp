// The command line as a technician and a lab script see it: output, messages, exit codes.
#include <gtest/gtest.h>

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
