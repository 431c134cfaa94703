#include <gtest/gtest.h>

#include <cstdio>

#include "paintlab/core/progress.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {
std::string read_all(std::FILE* f) {
  std::rewind(f);
  std::string s;
  char buf[512];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  return s;
}
}  // namespace

TEST(Progress, Formats) {
  EXPECT_EQ(Progress::format_duration(7.25), "7.2s");
  EXPECT_EQ(Progress::format_duration(245), "4:05");
  EXPECT_EQ(Progress::format_duration(3723), "1:02:03");
  EXPECT_EQ(Progress::render_bar(0.5, 10), "[#####>....]");
  EXPECT_EQ(Progress::render_bar(1.0, 4), "[####]");
}

TEST(Progress, PlainLinesWhenNotATerminal) {
  std::FILE* f = std::tmpfile();
  {
    Progress p("measure", 4, "pos", f);
    p.set_terminal(false);
    p.set_min_interval(0);
    p.update(1, "angle 0 deg");
    p.update(2);
    p.finish();
  }
  std::string s = read_all(f);
  std::fclose(f);
  EXPECT_THAT(s, HasSubstr("measure 1/4 pos (25%)"));
  EXPECT_THAT(s, HasSubstr("angle 0 deg"));
  EXPECT_THAT(s, HasSubstr("done in"));
  EXPECT_EQ(s.find('\r'), std::string::npos) << "no carriage returns in logs";
}

TEST(Progress, BarAndEtaOnATerminal) {
  std::FILE* f = std::tmpfile();
  {
    Progress p("fit", 10, "", f);
    p.set_terminal(true);
    p.set_min_interval(0);
    p.update(5);
  }
  std::string s = read_all(f);
  std::fclose(f);
  EXPECT_THAT(s, HasSubstr("\r"));
  EXPECT_THAT(s, HasSubstr("[###############>"));
  EXPECT_THAT(s, HasSubstr("ETA"));
}
