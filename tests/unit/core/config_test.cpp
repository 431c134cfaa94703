#include <gtest/gtest.h>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {
ConfigError config_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e;
  }
  ADD_FAILURE() << "no ConfigError thrown";
  return ConfigError("", 0, "", "");
}
}  // namespace

TEST(Config, ReadsTypedValues) {
  auto t = ConfigTable::parse_string("a = 1.5\nb = 3\nc = \"x\"\nd = true\ne = [1, 2.5, 3]\n[s]\nf = 2\n", "t.toml");
  EXPECT_DOUBLE_EQ(t.number("a"), 1.5);
  EXPECT_DOUBLE_EQ(t.number("b"), 3.0);  // integers are numbers too
  EXPECT_EQ(t.integer("b"), 3);
  EXPECT_EQ(t.string("c"), "x");
  EXPECT_TRUE(t.boolean("d"));
  EXPECT_EQ(t.numbers("e", 3, 3), (std::vector<double>{1, 2.5, 3}));
  auto s = t.table("s");
  EXPECT_EQ(s.integer("f"), 2);
  EXPECT_EQ(s.path("f"), "s.f");
  EXPECT_NO_THROW(s.finish());
  EXPECT_NO_THROW(t.finish());
}

TEST(Config, DefaultsWhenAbsent) {
  auto t = ConfigTable::parse_string("", "t.toml");
  EXPECT_DOUBLE_EQ(t.number("x", 4.0, Bounds::positive()), 4.0);
  EXPECT_EQ(t.string("y", "z"), "z");
  EXPECT_FALSE(t.maybe_number("w").has_value());
  EXPECT_FALSE(t.maybe_table("q").has_value());
}

TEST(Config, UnknownKeyNamesFileLineAndKey) {
  auto t = ConfigTable::parse_string("a = 1\n[geometry]\nradius = 2\nradiuss = 3\n", "rig.toml");
  t.number("a");
  auto g = t.table("geometry");
  g.number("radius");
  auto e = config_error_of([&] { g.finish(); });
  EXPECT_EQ(e.file(), "rig.toml");
  EXPECT_EQ(e.line(), 4);
  EXPECT_EQ(e.key(), "geometry.radiuss");
  EXPECT_THAT(std::string(e.what()), HasSubstr("rig.toml:4: key 'geometry.radiuss': unknown key in [geometry]"));
}

TEST(Config, WrongTypeIsNamed) {
  auto t = ConfigTable::parse_string("[plan]\nstep = \"one\"\n", "rig.toml");
  auto e = config_error_of([&] { t.table("plan").number("step"); });
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.key(), "plan.step");
  EXPECT_THAT(e.detail(), HasSubstr("expected a number, got a string"));
}

TEST(Config, OutOfRangeStatesTheRule) {
  auto t = ConfigTable::parse_string("m = 1.5\nn = -1\n", "p.toml");
  auto e = config_error_of([&] { t.number("m", Bounds::open(0, 1)); });
  EXPECT_THAT(std::string(e.what()), HasSubstr("p.toml:1: key 'm': must be in (0, 1) (got 1.5)"));
  auto e2 = config_error_of([&] { t.number("n", Bounds::positive()); });
  EXPECT_THAT(e2.detail(), HasSubstr("must be > 0 (got -1)"));
}

TEST(Config, MissingRequiredKey) {
  auto t = ConfigTable::parse_string("[geometry]\nx = 1\n", "rig.toml");
  auto e = config_error_of([&] { t.table("geometry").number("sphere_radius_m"); });
  EXPECT_EQ(e.key(), "geometry.sphere_radius_m");
  EXPECT_THAT(e.detail(), HasSubstr("required key is missing in [geometry]"));
}

TEST(Config, ChoiceListsAllowedValues) {
  auto t = ConfigTable::parse_string("kind = \"modbus\"\n", "rig.toml");
  auto e = config_error_of([&] { t.choice("kind", {"modbus-tcp", "modbus-rtu"}); });
  EXPECT_THAT(e.detail(), HasSubstr("\"modbus\" is not one of \"modbus-tcp\", \"modbus-rtu\""));
}

TEST(Config, ArrayLengthAndElements) {
  auto t = ConfigTable::parse_string("kd = [0.1, 0.2]\nks = [0.1, \"a\", 0.3]\nr = [0.1, 2, 0.3]\n", "paint.toml");
  EXPECT_THAT(config_error_of([&] { t.triple("kd"); }).detail(), HasSubstr("expected 3 values, got 2"));
  EXPECT_THAT(config_error_of([&] { t.triple("ks"); }).detail(), HasSubstr("element 1: expected a number"));
  EXPECT_THAT(config_error_of([&] { t.triple("r", Bounds::closed(0, 1)); }).detail(),
              HasSubstr("element 1 must be in [0, 1] (got 2)"));
}

TEST(Config, SyntaxErrorHasLine) {
  auto e = config_error_of([] { ConfigTable::parse_string("a = 1\nb = = 2\n", "bad.toml"); });
  EXPECT_EQ(e.line(), 2);
  EXPECT_THAT(std::string(e.what()), HasSubstr("bad.toml:2: TOML syntax error"));
}

TEST(Config, ArrayOfTables) {
  auto t = ConfigTable::parse_string("[[lobes]]\nm = 0.3\n[[lobes]]\nm = 0.1\nx = 1\n", "p.toml");
  auto lobes = t.tables("lobes", 1, 3);
  ASSERT_EQ(lobes.size(), 2u);
  EXPECT_DOUBLE_EQ(lobes[1].number("m"), 0.1);
  auto e = config_error_of([&] { lobes[1].finish(); });
  EXPECT_EQ(e.key(), "lobes[1].x");
  EXPECT_EQ(e.line(), 5);
  EXPECT_THAT(config_error_of([&] { t.tables("lobes", 3, 3); }).detail(), HasSubstr("expected 3..3 entries, got 2"));
}

TEST(Config, MissingFileIsIoError) {
  EXPECT_THROW(ConfigTable::parse_file("/nonexistent/rig.toml"), IoError);
}
