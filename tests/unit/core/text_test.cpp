// UTF-8 validation of what users type (core/text.h): RFC 3629's rules, the offset of the
// first bad byte.
#include "paintlab/core/text.h"

#include <gtest/gtest.h>

#include <string>

using namespace paintlab;

TEST(Text, ValidUtf8OfEveryLengthPasses) {
  EXPECT_EQ(first_invalid_utf8(""), std::string_view::npos);
  EXPECT_EQ(first_invalid_utf8("silver metallic 2026"), std::string_view::npos);
  EXPECT_EQ(first_invalid_utf8("caf\xc3\xa9 \xe2\x82\xac \xf0\x9d\x84\x9e"), std::string_view::npos);  // é € 𝄞
  EXPECT_EQ(first_invalid_utf8("\xf4\x8f\xbf\xbf"), std::string_view::npos);  // U+10FFFF, the last
}

TEST(Text, TheFirstBadByteIsFound) {
  EXPECT_EQ(first_invalid_utf8("blue\xff"), 4u);              // not a lead byte
  EXPECT_EQ(first_invalid_utf8("ab\x80"), 2u);                // a continuation without a lead
  EXPECT_EQ(first_invalid_utf8("caf\xc3"), 3u);               // cut short
  EXPECT_EQ(first_invalid_utf8("x\xe2\x82"), 1u);             // cut short in a 3-byte form
  EXPECT_EQ(first_invalid_utf8("\xc0\xaf"), 0u);              // overlong '/'
  EXPECT_EQ(first_invalid_utf8("\xe0\x80\xaf"), 0u);          // overlong in 3 bytes
  EXPECT_EQ(first_invalid_utf8("ok\xed\xa0\x80"), 2u);        // a surrogate
  EXPECT_EQ(first_invalid_utf8("\xf4\x90\x80\x80"), 0u);      // above U+10FFFF
  EXPECT_EQ(first_invalid_utf8("\xc3\xa9\xc3("), 2u);          // a bad continuation after a good character
  const std::string with_nul("a\0b", 3);
  EXPECT_EQ(first_invalid_utf8(with_nul), std::string_view::npos);  // NUL is valid UTF-8
}
