// Demosaicing (acquisition/demosaic.h) pinned on synthetic mosaics: a scene of known colour
// is sampled through each of the four GenICam arrangements and must come back in the right
// channels (OpenCV names the arrangements differently; a wrong translation swaps red and blue
// or puts green where red belongs).
#include "paintlab/acquisition/demosaic.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <random>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using dev::CfaPattern;
using acq::demosaic;
using acq::demosaic_merged;
using acq::cfa_luminance;
using acq::DemosaicMethod;

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

// ---- the merged radiance mosaic (float, with variance and validity) ----

namespace {

// A merged mosaic (Y, var.Y, valid) of a scene: each pixel its filter's colour, variance v.
ExrImage merged_mosaic_of(int w, int h, CfaPattern pattern, const std::function<double(int, int, int)>& scene,
                          double var = 4.0) {
  ExrImage m;
  m.width = w;
  m.height = h;
  ImageF y(w, h, 1), v(w, h, 1, static_cast<float>(var)), ok(w, h, 1, 1.0f);
  for (int py = 0; py < h; ++py)
    for (int px = 0; px < w; ++px) y.at(px, py) = static_cast<float>(scene(px, py, dev::cfa_colour(pattern, px, py)));
  m.add("Y", std::move(y));
  m.add("var.Y", std::move(v));
  m.add("valid", std::move(ok));
  m.attributes["paintlab.content"] = "merged radiance";
  return m;
}

}  // namespace

TEST(DemosaicMerged, AUniformColourComesBackExactlyEverywhereForEveryArrangement) {
  for (CfaPattern p : kPatterns) {
    SCOPED_TRACE(dev::to_string(p));
    const ExrImage rgb = demosaic_merged(merged_mosaic_of(12, 10, p, [](int, int, int c) { return 100.0 + 1000.0 * c; }), p);
    EXPECT_EQ(rgb.names, (std::vector<std::string>{"R", "G", "B", "var.R", "var.G", "var.B", "valid"}));
    EXPECT_EQ(rgb.attributes.at("paintlab.content"), "merged radiance");
    for (int y = 0; y < 10; ++y)
      for (int x = 0; x < 12; ++x) {  // borders included: the weights renormalise
        EXPECT_FLOAT_EQ(rgb.plane("R").at(x, y), 100.0f);
        EXPECT_FLOAT_EQ(rgb.plane("G").at(x, y), 1100.0f);
        EXPECT_FLOAT_EQ(rgb.plane("B").at(x, y), 2100.0f);
      }
  }
}

TEST(DemosaicMerged, ALinearSceneIsReproducedAndAgreesWithOpenCvsBilinear) {
  const auto scene = [](int x, int y, int c) { return 2000.0 + 150.0 * x + 90.0 * y + 3000.0 * c; };
  for (CfaPattern p : kPatterns) {
    SCOPED_TRACE(dev::to_string(p));
    const ExrImage rgb = demosaic_merged(merged_mosaic_of(16, 12, p, scene), p);
    const Image<std::uint16_t> cv = demosaic(mosaic_of(16, 12, p, [&](int x, int y, int c) {
      return static_cast<int>(scene(x, y, c));
    }), p, DemosaicMethod::Bilinear);
    const char* names[3] = {"R", "G", "B"};
    for (int y = 1; y < 11; ++y)
      for (int x = 1; x < 15; ++x)
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(rgb.plane(names[c]).at(x, y), scene(x, y, c), 1e-3) << x << "," << y << " " << names[c];
          EXPECT_NEAR(rgb.plane(names[c]).at(x, y), cv.at(x, y, c), 1.0) << x << "," << y << " " << names[c];
        }
  }
}

TEST(DemosaicMerged, VarianceFollowsTheWeightsAndAnInvalidSiteInvalidatesItsNeighbours) {
  const CfaPattern p = CfaPattern::RG;  // R G / G B
  ExrImage m = merged_mosaic_of(8, 8, p, [](int, int, int) { return 500.0; }, 4.0);
  m.find("valid")->at(4, 4) = 0.0f;  // an R site (even, even): a hot pixel
  const ExrImage rgb = demosaic_merged(m, p);
  // At the R site (2, 2): R its own (var 4), G the mean of 4 (var 4/4), B the mean of 4 diagonals (var 1).
  EXPECT_FLOAT_EQ(rgb.plane("var.R").at(2, 2), 4.0f);
  EXPECT_FLOAT_EQ(rgb.plane("var.G").at(2, 2), 1.0f);
  EXPECT_FLOAT_EQ(rgb.plane("var.B").at(2, 2), 1.0f);
  // At the G site (3, 2) between two reds: R is their mean (var 2).
  EXPECT_FLOAT_EQ(rgb.plane("var.R").at(3, 2), 2.0f);
  // The invalid R site at (4, 4) spoils R wherever it is used: its 3x3 neighbourhood.
  for (int y = 3; y <= 5; ++y)
    for (int x = 3; x <= 5; ++x) {
      EXPECT_EQ(rgb.plane("valid").at(x, y), 0.0f) << x << "," << y;
      EXPECT_TRUE(std::isinf(rgb.plane("var.R").at(x, y)));
    }
  EXPECT_EQ(rgb.plane("valid").at(2, 2), 1.0f);
  EXPECT_EQ(rgb.plane("valid").at(6, 4), 1.0f);  // the next R site uses only itself for R
  EXPECT_FALSE(std::isinf(rgb.plane("var.G").at(4, 3)));
  // A green site keeps its own green (not smoothed with its diagonal greens): a single-pixel
  // glint stays one pixel in green.
  ExrImage spot = merged_mosaic_of(8, 8, p, [](int x, int y, int) { return x == 3 && y == 2 ? 900.0 : 100.0; }, 4.0);
  const ExrImage g = demosaic_merged(spot, p);
  EXPECT_FLOAT_EQ(g.plane("G").at(3, 2), 900.0f);
  EXPECT_FLOAT_EQ(g.plane("var.G").at(3, 2), 4.0f);
  EXPECT_FLOAT_EQ(g.plane("G").at(4, 3), 100.0f);  // its diagonal green neighbour is untouched
}

TEST(DemosaicToColour, TheColourMapMixesTheBalancedChannelsAndCarriesTheVariance) {
  const CfaPattern p = CfaPattern::GB;
  ExrImage m = merged_mosaic_of(10, 8, p, [](int, int, int c) { return c == 0 ? 200.0 : c == 1 ? 400.0 : 100.0; }, 4.0);
  acq::ColourMap map;
  map.pattern = p;
  map.balance = {2.0, 1.0, 4.0};  // camera (200, 400, 100) balanced to (400, 400, 400): grey
  map.matrix = std::array<double, 9>{0.9, 0.2, -0.1, 0.0, 1.0, 0.0, -0.05, 0.1, 0.95};
  map.colour_space = colour::kLinearSrgb;
  const ExrImage out = acq::demosaic_to_colour(m, map);
  EXPECT_EQ(out.attributes.at("paintlab.colour_space"), "linear sRGB (D65)");
  EXPECT_EQ(out.attributes.at("paintlab.cfa"), "GB");
  EXPECT_EQ(out.find("Y"), nullptr);
  for (auto [x, y] : {std::pair{0, 0}, std::pair{4, 4}, std::pair{5, 3}, std::pair{9, 7}}) {
    SCOPED_TRACE(::testing::Message() << x << "," << y);
    EXPECT_NEAR(out.plane("R").at(x, y), 400.0, 1e-3);  // each row of the matrix sums to 1
    EXPECT_NEAR(out.plane("G").at(x, y), 400.0, 1e-3);
    EXPECT_NEAR(out.plane("B").at(x, y), 400.0, 1e-3);
  }
  // The variance at an interior red site of GB (G B / R G: x even, y odd): R its own (4), G the
  // mean of 4 (1), B the mean of 4 diagonals (1); balanced by 4, 1, 16; mixed by M^2.
  const double vr = 4 * 4, vg = 1 * 1, vb = 1 * 16;
  EXPECT_NEAR(out.plane("var.R").at(4, 3), 0.81 * vr + 0.04 * vg + 0.01 * vb, 1e-3);
  EXPECT_NEAR(out.plane("var.G").at(4, 3), vg, 1e-4);
  EXPECT_NEAR(out.plane("var.B").at(4, 3), 0.0025 * vr + 0.01 * vg + 0.9025 * vb, 1e-3);
  // One invalid site spoils every output channel that mixes its colour in.
  m.find("valid")->at(4, 3) = 0.0f;
  const ExrImage bad = acq::demosaic_to_colour(m, map);
  EXPECT_EQ(bad.plane("valid").at(4, 3), 0.0f);
  EXPECT_TRUE(std::isinf(bad.plane("var.R").at(4, 3)));
  EXPECT_FALSE(std::isinf(bad.plane("var.G").at(4, 3)));  // the G row takes no red
  EXPECT_TRUE(std::isinf(bad.plane("var.B").at(4, 3)));
  // A non-linear map: the same values through a function, the variance through its Jacobian.
  acq::ColourMap square = map;
  square.matrix.reset();
  square.nonlinear = [](const std::array<double, 3>& b) { return std::array<double, 3>{b[0] * b[0] / 400.0, b[1], b[2]}; };
  m.find("valid")->at(4, 3) = 1.0f;
  const ExrImage nl = acq::demosaic_to_colour(m, square);
  EXPECT_NEAR(nl.plane("R").at(4, 3), 400.0, 1e-3);
  EXPECT_NEAR(nl.plane("var.R").at(4, 3), 4.0 * vr, 0.01 * 4.0 * vr);  // d(b^2/400)/db = 2 at b = 400
  EXPECT_THROW(acq::demosaic_to_colour(m, acq::ColourMap{}), DataError);  // no pattern
}

TEST(DemosaicMerged, LuminanceOfAMosaicIsAQuarterRedHalfGreenAQuarterBlue) {
  const auto scene = [](int, int, int c) { return c == 0 ? 400.0 : c == 1 ? 1000.0 : 2000.0; };
  for (CfaPattern p : kPatterns) {
    const ExrImage m = merged_mosaic_of(10, 8, p, scene);
    const ImageF lum = cfa_luminance(m.plane("Y"));
    for (int y = 1; y < 7; ++y)
      for (int x = 1; x < 9; ++x) EXPECT_NEAR(lum.at(x, y), (400.0 + 2 * 1000.0 + 2000.0) / 4, 1e-3) << dev::to_string(p);
  }
  EXPECT_THROW(cfa_luminance(ImageF(4, 4, 3)), DataError);
  ExrImage no_var;
  no_var.width = no_var.height = 4;
  no_var.add("Y", ImageF(4, 4, 1));
  EXPECT_THAT(test::error_message<DataError>([&] { demosaic_merged(no_var, CfaPattern::RG); }),
              ::testing::HasSubstr("planes Y, var.Y and valid"));
}

TEST(DemosaicMerged, AGreyTargetsMosaicIsBalancedSoASmallSpotKeepsItsPlace) {
  // A grey scene through filters of gains 0.6 / 1.0 / 0.8 (RG): a bright spot one pixel wide
  // at a red site. Unbalanced, the luminance is pulled towards the green sites around it.
  const CfaPattern p = CfaPattern::RG;
  const double gain[3] = {0.6, 1.0, 0.8};
  ImageF mosaic(16, 16, 1);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const double scene = 100.0 + (x == 8 && y == 8 ? 5000.0 : 0.0) + 3.0 * x;
      mosaic.at(x, y) = static_cast<float>(gain[dev::cfa_colour(p, x, y)] * scene);
    }
  const auto gains = acq::grey_gains(mosaic, p, 20);
  ASSERT_TRUE(gains);
  const std::array<double, 3> g = *gains;
  const ImageF lum = acq::balanced_luminance(mosaic, p, g);
  EXPECT_FALSE(acq::grey_gains(mosaic, p, 1000));  // too few flat blocks for that many
  // (each colour's sites sample the ramp at other places: a per cent or two off)
  EXPECT_NEAR(g[0], 0.6, 0.02);
  EXPECT_NEAR(g[1], 1.0, 1e-12);
  EXPECT_NEAR(g[2], 0.8, 0.02);
  // Away from the spot, a grey ramp stays a ramp (no 2x2 pattern left).
  for (int x = 2; x < 6; ++x) EXPECT_NEAR(lum.at(x + 1, 3) - lum.at(x, 3), 3.0, 0.1) << x;
  // The spot's centroid stays on its pixel, in x and in y.
  double sx = 0, sy = 0, s = 0;
  for (int y = 6; y <= 10; ++y)
    for (int x = 6; x <= 10; ++x) {
      const double v = lum.at(x, y) - (100.0 + 3.0 * x);
      sx += v * x;
      sy += v * y;
      s += v;
    }
  EXPECT_NEAR(sx / s, 8.0, 0.02);
  EXPECT_NEAR(sy / s, 8.0, 0.02);
}

TEST(DemosaicToColour, TheRowKernelsAgreeWithTheGeneralPathForEveryArrangement) {
  // The linear map takes the specialised row kernels; the same map given as a function takes
  // the general neighbourhood code: both must give the same image, invalid sites included.
  const std::array<double, 9> m{1.5, -0.4, -0.1, -0.2, 1.3, -0.1, 0.05, -0.3, 1.25};
  for (CfaPattern p : kPatterns) {
    SCOPED_TRACE(dev::to_string(p));
    std::uint32_t state = 12345u + static_cast<std::uint32_t>(p);
    auto next = [&] {
      state = state * 1664525u + 1013904223u;
      return (state >> 8) / 16777216.0;
    };
    ExrImage mosaic = merged_mosaic_of(13, 9, p, [&](int, int, int) { return 50.0 + 1000.0 * next(); });
    for (float& v : mosaic.find("var.Y")->values()) v = static_cast<float>(1.0 + 10.0 * next());
    for (float& v : mosaic.find("valid")->values()) v = next() < 0.05 ? 0.0f : 1.0f;
    acq::ColourMap fast;
    fast.pattern = p;
    fast.balance = {1.7, 1.0, 1.2};
    fast.matrix = m;
    acq::ColourMap general = fast;
    general.nonlinear = [m](const std::array<double, 3>& b) {
      return std::array<double, 3>{m[0] * b[0] + m[1] * b[1] + m[2] * b[2], m[3] * b[0] + m[4] * b[1] + m[5] * b[2],
                                   m[6] * b[0] + m[7] * b[1] + m[8] * b[2]};
    };
    const ExrImage a = acq::demosaic_to_colour(mosaic, fast);
    const ExrImage b = acq::demosaic_to_colour(mosaic, general);
    for (const char* c : {"R", "G", "B", "var.R", "var.G", "var.B", "valid"})
      for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 13; ++x) {
          const float u = a.plane(c).at(x, y), v = b.plane(c).at(x, y);
          if (std::isinf(v)) {
            EXPECT_TRUE(std::isinf(u)) << c << " " << x << "," << y;
          } else {
            EXPECT_NEAR(u, v, 1e-3 * std::max(1.0f, std::abs(v))) << c << " " << x << "," << y;
          }
        }
  }
}

// ---- gradient-corrected demosaicing (Malvar, He and Cutler 2004) ----

namespace {

acq::ColourMap gradient_map(CfaPattern p) {
  acq::ColourMap map;
  map.pattern = p;
  map.interpolation = acq::MosaicInterpolation::GradientCorrected;
  return map;
}

}  // namespace

TEST(DemosaicGradientCorrected, AColourWithACommonGradientComesBackExactlyForEveryArrangement) {
  // Every kernel sums to 1 in its own colour and its correction term to 0, and all are
  // symmetric: a constant colour plus a gradient shared by the channels is reproduced.
  const auto scene = [](int x, int y, int c) { return 1000.0 + 2000.0 * c + 37.0 * x - 21.0 * y; };
  for (CfaPattern p : kPatterns) {
    SCOPED_TRACE(dev::to_string(p));
    const ExrImage rgb = acq::demosaic_to_colour(merged_mosaic_of(14, 12, p, scene), gradient_map(p));
    EXPECT_EQ(rgb.attributes.at("paintlab.demosaic"), "gradient-corrected");
    const char* names[3] = {"R", "G", "B"};
    for (int y = 1; y < 11; ++y)
      for (int x = 1; x < 13; ++x)
        for (int c = 0; c < 3; ++c)  // and the bilinear ring next to the border
          ASSERT_NEAR(rgb.plane(names[c]).at(x, y), scene(x, y, c), 2e-3 * scene(x, y, c))
              << x << "," << y << " " << names[c];
  }
}

TEST(DemosaicGradientCorrected, ANarrowGreyHighlightIsReconstructedCloserThanBilinear) {
  // A grey Gaussian spot (sigma 1.2 px, off the pixel grid) seen through camera gains 0.55,
  // 1.0, 0.75 and balanced back: what a clear coat's highlight is on the quick rig.
  const double gains[3] = {0.55, 1.0, 0.75};
  const auto grey = [](int x, int y) {
    const double dx = x - 15.3, dy = y - 14.6;
    return 50.0 + 5000.0 * std::exp(-(dx * dx + dy * dy) / (2.0 * 1.2 * 1.2));
  };
  for (CfaPattern p : kPatterns) {
    SCOPED_TRACE(dev::to_string(p));
    const ExrImage m = merged_mosaic_of(32, 30, p, [&](int x, int y, int c) { return gains[c] * grey(x, y); });
    acq::ColourMap bil;
    bil.pattern = p;
    bil.balance = {1.0 / gains[0], 1.0, 1.0 / gains[2]};
    acq::ColourMap mhc = bil;
    mhc.interpolation = acq::MosaicInterpolation::GradientCorrected;
    const ExrImage a = acq::demosaic_to_colour(m, bil), b = acq::demosaic_to_colour(m, mhc);
    // The error against the truth, and the spot's width as a fit sees it: every kernel keeps
    // the spot's volume, so its height says its width (volume / height = 2 pi sigma^2); the
    // height per channel, averaged over the three.
    double ss_a = 0, ss_b = 0, peak_a = 0, peak_b = 0, peak_true = 0;
    const char* names[3] = {"R", "G", "B"};
    for (int y = 6; y < 24; ++y)
      for (int x = 6; x < 25; ++x) {
        peak_true = std::max(peak_true, grey(x, y) - 50.0);
        for (int c = 0; c < 3; ++c) {
          const double va = a.plane(names[c]).at(x, y), vb = b.plane(names[c]).at(x, y);
          ss_a += (va - grey(x, y)) * (va - grey(x, y));
          ss_b += (vb - grey(x, y)) * (vb - grey(x, y));
          if (x == 15 && y == 15) {  // the brightest pixel
            peak_a += (va - 50.0) / 3.0;
            peak_b += (vb - 50.0) / 3.0;
          }
        }
      }
    EXPECT_LT(std::sqrt(ss_b), 0.4 * std::sqrt(ss_a));
    EXPECT_NEAR(peak_b / peak_true, 1.0, 0.07);
    EXPECT_LT(peak_a / peak_true, 0.85);
  }
}

TEST(DemosaicGradientCorrected, TheVarianceIsTheSpreadOfRepeatedNoisyMergesThroughTheMatrix) {
  // Independent noise of a known variance at every site, 4000 repeats: the reported variance of
  // each output at each of the four kinds of site matches the sample variance (the channels of
  // a pixel share sites, so the matrix's off-diagonal terms bring their covariance in).
  const CfaPattern p = CfaPattern::RG;
  acq::ColourMap map = gradient_map(p);
  map.balance = {1.8, 1.0, 1.3};
  map.matrix = std::array<double, 9>{1.2, -0.3, 0.1, -0.2, 1.3, -0.1, 0.05, -0.25, 1.2};
  const int w = 10, h = 10, n = 4000;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto site_sd = [](int x, int y) { return 2.0 + 0.5 * ((x + 2 * y) % 3); };  // not uniform
  const std::array<std::pair<int, int>, 4> pixels{{{4, 4}, {5, 4}, {4, 5}, {5, 5}}};  // R, G, G, B
  std::array<std::array<double, 3>, 4> sum{}, sum2{};
  ExrImage reported;
  for (int k = 0; k < n; ++k) {
    ExrImage m = merged_mosaic_of(w, h, p, [&](int x, int y, int) { return 300.0 + site_sd(x, y) * noise(rng); });
    ImageF& v = *m.find("var.Y");
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) v.at(x, y) = static_cast<float>(site_sd(x, y) * site_sd(x, y));
    const ExrImage out = acq::demosaic_to_colour(m, map);
    const char* names[3] = {"R", "G", "B"};
    for (std::size_t i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) {
        const double o = out.plane(names[c]).at(pixels[i].first, pixels[i].second);
        sum[i][static_cast<std::size_t>(c)] += o;
        sum2[i][static_cast<std::size_t>(c)] += o * o;
      }
    if (k == 0) reported = out;
  }
  const char* vars[3] = {"var.R", "var.G", "var.B"};
  for (std::size_t i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) {
      const double mean = sum[i][static_cast<std::size_t>(c)] / n;
      const double sample = sum2[i][static_cast<std::size_t>(c)] / n - mean * mean;
      const double want = reported.plane(vars[c]).at(pixels[i].first, pixels[i].second);
      EXPECT_NEAR(sample / want, 1.0, 0.07) << "pixel " << i << " channel " << c;  // 4000 samples: sd 2.2 %
    }
}

TEST(DemosaicGradientCorrected, AnInvalidSiteInvalidatesItsFiveByFiveNeighbourhoodAndTheNameIsChecked) {
  const CfaPattern p = CfaPattern::BG;
  ExrImage m = merged_mosaic_of(12, 12, p, [](int, int, int c) { return 100.0 + c; });
  m.find("valid")->at(6, 6) = 0.0f;
  const ExrImage out = acq::demosaic_to_colour(m, gradient_map(p));
  // Sites two apart in a row or column read it (the correction term), diagonal ones two apart do not.
  EXPECT_EQ(out.plane("valid").at(4, 6), 0.0f);
  EXPECT_EQ(out.plane("valid").at(6, 8), 0.0f);
  EXPECT_EQ(out.plane("valid").at(8, 8), 1.0f);
  EXPECT_EQ(out.plane("valid").at(6, 9), 1.0f);
  EXPECT_EQ(acq::mosaic_interpolation_from_string("gradient-corrected", "--demosaic"),
            acq::MosaicInterpolation::GradientCorrected);
  EXPECT_THAT([] { acq::mosaic_interpolation_from_string("vng", "--demosaic"); },
              ::testing::ThrowsMessage<DataError>(::testing::AllOf(::testing::HasSubstr("--demosaic"),
                                                                   ::testing::HasSubstr("gradient-corrected"))));
}
