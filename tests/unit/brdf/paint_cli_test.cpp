// `paintlab paint validate`: what a technician sees for a good and a bad paint file.
#include <gtest/gtest.h>

#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

TEST(PaintCli, ValidatePrintsTheShippedPaints) {
  auto r = test::run_paintlab("paint validate " + (test::source_dir() / "paints/silver-metallic.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("paint 'silver-metallic'"));
  EXPECT_THAT(r.out, HasSubstr(": valid"));
  EXPECT_THAT(r.out, HasSubstr("lobe 3"));
  EXPECT_THAT(r.out, HasSubstr("m 0.015"));
  EXPECT_THAT(r.out, HasSubstr("carry lobe(s) 1, 2"));
  r = test::run_paintlab("paint validate " + (test::source_dir() / "paints/pearlescent.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("layered-pearlescent"));
  r = test::run_paintlab("paint validate --json " + (test::source_dir() / "paints/solid-blue.toml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"model\": \"cook-torrance\""));
  EXPECT_THAT(r.out, HasSubstr("\"lobes\": ["));
}

TEST(PaintCli, BadFileExitsTwoWithFileLineKey) {
  test::TempDir d;
  test::write_text(d / "bad.toml", "name = \"bad\"\nmodel = \"cook-torrance\"\nkd = [0.1, 0.1, 0.1]\n"
                                   "[[lobes]]\nks = [0.1, 0.1, 0.1]\nm = 1.2\nr = 0.5\n");
  auto r = test::run_paintlab("paint validate " + (d / "bad.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("bad.toml:6: key 'lobes[0].m': must be in (0, 1) (got 1.2)"));
  EXPECT_EQ(r.out, "");
  r = test::run_paintlab("paint validate " + (d / "missing.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("missing.toml: no such file"));
  r = test::run_paintlab("paint validate");
  EXPECT_EQ(r.exit_code, 2);
}
