// Demosaicing (acquisition/demosaic.h) pinned on synthetic mosaics: a scene of known colour
// is sampled through each of the four GenICam arrangements and must come back in the right
// channels (OpenCV names the arrangements differently; a wrong translation swaps red and blue
// or puts green where red belongs).
#include "paintlab/acquisition/demosaic.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <functional>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using dev::CfaPattern;

namespace {

constexpr std::array<CfaPattern, 4> kPatterns{CfaPattern::RG, CfaPattern::GR, CfaPattern::GB, CfaPattern::BG};

// The mosaic a `pattern` sensor records of a scene whose colour at (x, y) is rgb(x, y, c).
Image<std::uint16_t> mosaic_of(int w, int h, CfaPattern pattern, const std::function<int(int, int, int)>& rgb) {
  Image<std::uint16_t> m(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) m.at(x, y, 0) = static_cast<std::uint16_t>(rgb(x, y, dev::cfa_colour(pattern, x, y)));
  return m;
}

// The largest difference from the scene over the pixels at least `border` from the edge.
int worst_inside(const Image<std::uint16_t>& rgb, const std::function<int(int, int, int)>& scene, int border) {
  int worst = 0;
  for (int y = border; y < rgb.height() - border; ++y)
    for (int x = border; x < rgb.width() - border; ++x)
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(rgb.at(x, y, c) - scene(x, y, c)));
  return worst;
}

}  // namespace

TEST(Demosaic, AUniformColourComesBackInItsChannelsForEveryArrangement) {
  const auto scene = [](int, int, int c) { return std::array{1000, 2000, 30000}[static_cast<std::size_t>(c)]; };
  for (CfaPattern p : kPatterns)
    for (acq::DemosaicMethod m : {acq::DemosaicMethod::Bilinear, acq::DemosaicMethod::EdgeAware}) {
      const Image<std::uint16_t> rgb = acq::demosaic(mosaic_of(16, 12, p, scene), p, m);
      ASSERT_EQ(rgb.channels(), 3);
      ASSERT_EQ(rgb.width(), 16);
      EXPECT_EQ(worst_inside(rgb, scene, 2), 0) << dev::to_string(p) << " " << acq::to_string(m)
                                                << ": at (5, 5) R G B = " << rgb.at(5, 5, 0) << " " << rgb.at(5, 5, 1)
                                                << " " << rgb.at(5, 5, 2);
    }
}

// Bilinear interpolation reproduces a linear scene: each missing value is the mean of
// neighbours placed symmetrically around it. 16-bit values above 8 bits stay exact.
TEST(Demosaic, BilinearReproducesALinearSceneWithSixteenBitValues) {
  const auto scene = [](int x, int y, int c) {
    switch (c) {
      case 0: return 300 + 40 * x;
      case 1: return 5000 + 28 * y;
      default: return 20000 + 12 * x + 20 * y;
    }
  };
  for (CfaPattern p : kPatterns) {
    const Image<std::uint16_t> rgb = acq::demosaic(mosaic_of(40, 30, p, scene), p, acq::DemosaicMethod::Bilinear);
    EXPECT_LE(worst_inside(rgb, scene, 2), 1) << dev::to_string(p);
  }
}

TEST(Demosaic, WhatIsNoMosaicIsRefused) {
  Image<std::uint16_t> rgb(8, 8, 3);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::demosaic(rgb, CfaPattern::RG); }), ::testing::HasSubstr("one plane"));
  Image<std::uint16_t> mono(8, 8, 1);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::demosaic(mono, CfaPattern::None); }),
              ::testing::HasSubstr("no colour filter array"));
  EXPECT_THAT(test::error_message<DataError>([] { acq::demosaic_method_from_string("vng", "--demosaic"); }),
              ::testing::AllOf(::testing::HasSubstr("--demosaic"), ::testing::HasSubstr("edge-aware")));
}
