#include "paintlab/core/enum_names.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace paintlab {
namespace {

using ::testing::HasSubstr;

enum class Colour { Red, Green, Blue };
constexpr EnumNames<Colour, 3> kColourNames{{{Colour::Red, "red"}, {Colour::Green, "green"}, {Colour::Blue, "blue"}}};

TEST(EnumNames, EveryNameReadsBackToItsValue) {
  for (const auto& [value, name] : kColourNames) {
    EXPECT_STREQ(enum_name(kColourNames, value), name);
    EXPECT_EQ(enum_from_name(kColourNames, name, "colour"), value);
  }
  static_assert(enum_name(kColourNames, Colour::Green)[0] == 'g');  // usable at compile time
}

TEST(EnumNames, AValueOutsideTheTableGetsTheFallback) {
  EXPECT_STREQ(enum_name(kColourNames, static_cast<Colour>(7)), "?");
  EXPECT_STREQ(enum_name(kColourNames, static_cast<Colour>(7), "red"), "red");
}

TEST(EnumNames, AnUnknownNameIsADataErrorNamingWhereWhatAndEveryChoice) {
  EXPECT_THAT(test::error_message<DataError>([&] { enum_from_name(kColourNames, "Red", "colour", "paint.toml:3: key 'tint'"); }),
              HasSubstr("paint.toml:3: key 'tint': unknown colour 'Red' (expected red, green or blue)"));
  // Without a place the message starts with what was wrong.
  EXPECT_THAT(test::error_message<DataError>([&] { enum_from_name(kColourNames, "", "colour"); }),
              HasSubstr("unknown colour '' (expected red, green or blue)"));
}

TEST(EnumNames, ChoicesReadAsAList) {
  constexpr EnumNames<Colour, 1> one{{{Colour::Red, "red"}}};
  constexpr EnumNames<Colour, 2> two{{{Colour::Red, "red"}, {Colour::Blue, "blue"}}};
  EXPECT_EQ(enum_choices(one), "red");
  EXPECT_EQ(enum_choices(two), "red or blue");
  EXPECT_EQ(enum_choices(kColourNames), "red, green or blue");
}

}  // namespace
}  // namespace paintlab
