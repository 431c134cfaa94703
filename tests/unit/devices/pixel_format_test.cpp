// The camera's pixel formats (devices/camera.h): GenICam names, bit depths, channels, and the
// colour each pixel of a Bayer mosaic records, named as GenICam names the arrangement.
#include "paintlab/devices/camera.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::dev;

TEST(PixelFormat, NamesRoundTripWithTheirDepthsAndChannels) {
  struct Case {
    const char* name;
    int bits, channels;
    CfaPattern cfa;
  };
  for (const Case& c : {Case{"Mono8", 8, 1, CfaPattern::None}, Case{"Mono12", 12, 1, CfaPattern::None},
                        Case{"Mono16", 16, 1, CfaPattern::None}, Case{"BayerRG8", 8, 1, CfaPattern::RG},
                        Case{"BayerGR12", 12, 1, CfaPattern::GR}, Case{"BayerGB16", 16, 1, CfaPattern::GB},
                        Case{"BayerBG12", 12, 1, CfaPattern::BG}, Case{"RGB8", 8, 3, CfaPattern::None}}) {
    const PixelFormat f = pixel_format_from_string(c.name);
    EXPECT_STREQ(to_string(f), c.name);
    EXPECT_EQ(bit_depth(f), c.bits) << c.name;
    EXPECT_EQ(channels(f), c.channels) << c.name;
    EXPECT_EQ(cfa_pattern(f), c.cfa) << c.name;
  }
  EXPECT_THAT(test::error_message<DataError>([] { pixel_format_from_string("BayerRGGB8"); }),
              ::testing::AllOf(::testing::HasSubstr("pixel format 'BayerRGGB8'"), ::testing::HasSubstr("BayerRG12")));
}

// GenICam names the arrangement by the top-left 2x2 block, row by row: BayerRG is R G / G B.
TEST(PixelFormat, TheMosaicColourOfEachPixelFollowsTheTopLeftBlock) {
  const auto block = [](CfaPattern p) {
    return std::vector<int>{cfa_colour(p, 0, 0), cfa_colour(p, 1, 0), cfa_colour(p, 0, 1), cfa_colour(p, 1, 1)};
  };
  EXPECT_EQ(block(CfaPattern::RG), (std::vector<int>{0, 1, 1, 2}));
  EXPECT_EQ(block(CfaPattern::GR), (std::vector<int>{1, 0, 2, 1}));
  EXPECT_EQ(block(CfaPattern::GB), (std::vector<int>{1, 2, 0, 1}));
  EXPECT_EQ(block(CfaPattern::BG), (std::vector<int>{2, 1, 1, 0}));
  EXPECT_EQ(cfa_colour(CfaPattern::None, 3, 5), -1);
  // The block repeats: (x, y) and (x + 2, y + 4) record the same colour.
  for (CfaPattern p : {CfaPattern::RG, CfaPattern::GR, CfaPattern::GB, CfaPattern::BG})
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) EXPECT_EQ(cfa_colour(p, x + 2, y + 4), cfa_colour(p, x, y)) << to_string(p);
}
