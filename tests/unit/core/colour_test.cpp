// Colour science through LittleCMS: CIEDE2000 against Sharma, Wu and Dalal's published pairs,
// sRGB white and primaries in CIELAB, XYZ <-> Lab and Bradford round trips.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "paintlab/core/colour.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::colour;

TEST(Colour, CiedeMatchesSharmasPairs) {
  std::ifstream in(test::data_dir() / "ciede2000" / "sharma2005.txt");
  ASSERT_TRUE(in) << "tests/data/ciede2000/sharma2005.txt is missing";
  std::string line;
  int pairs = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    int id = 0;
    Lab a, b;
    double expected = 0.0;
    ASSERT_TRUE(s >> id >> a.L >> a.a >> a.b >> b.L >> b.a >> b.b >> expected) << line;
    // Published to four decimals; the formula is symmetric.
    EXPECT_NEAR(delta_e_2000(a, b), expected, 0.51e-4) << "pair " << id;
    EXPECT_NEAR(delta_e_2000(b, a), expected, 0.51e-4) << "pair " << id << " swapped";
    ++pairs;
  }
  EXPECT_EQ(pairs, 34);
}

// The parametric factors divide their term: a pure lightness difference counts half with
// kL = 2, a pure chroma difference half with kC = 2 (the tolerance sets of paintlab qc).
TEST(Colour, CiedeParametricFactorsScaleTheirTerm) {
  const Lab a{50.0, 20.0, 10.0};
  const Lab lighter{52.0, 20.0, 10.0};
  EXPECT_NEAR(delta_e_2000(a, lighter, 2.0, 1.0, 1.0), delta_e_2000(a, lighter) / 2.0, 1e-9);
  EXPECT_NEAR(delta_e_2000(a, lighter, 1.0, 2.0, 2.0), delta_e_2000(a, lighter), 1e-9);
  const Lab more_chroma{50.0, 24.0, 12.0};  // the same hue angle
  EXPECT_NEAR(delta_e_2000(a, more_chroma, 1.0, 2.0, 1.0), delta_e_2000(a, more_chroma) / 2.0, 1e-9);
}

TEST(Colour, SrgbWhiteIsLab100AndThePrimariesHaveTheirKnownLab) {
  const Lab white = srgb_to_lab(Rgb::Ones());
  EXPECT_NEAR(white.L, 100.0, 1e-9);
  EXPECT_NEAR(white.a, 0.0, 1e-9);
  EXPECT_NEAR(white.b, 0.0, 1e-9);
  // A grey of reflectance 0.18 is L* 49.50 (CIE 1976: 116 * 0.18^(1/3) - 16).
  EXPECT_NEAR(srgb_to_lab(Rgb::Constant(0.18)).L, 116.0 * std::cbrt(0.18) - 16.0, 1e-9);
  // The sRGB primaries (widely tabulated, D65, 2 deg): red 53.24 80.09 67.20, green 87.73
  // -86.18 83.18, blue 32.30 79.19 -107.86.
  const Lab r = srgb_to_lab(Rgb(1, 0, 0)), g = srgb_to_lab(Rgb(0, 1, 0)), b = srgb_to_lab(Rgb(0, 0, 1));
  EXPECT_NEAR(r.L, 53.24, 0.05);
  EXPECT_NEAR(r.a, 80.09, 0.1);
  EXPECT_NEAR(r.b, 67.20, 0.1);
  EXPECT_NEAR(g.L, 87.73, 0.05);
  EXPECT_NEAR(g.a, -86.18, 0.1);
  EXPECT_NEAR(g.b, 83.18, 0.1);
  EXPECT_NEAR(b.L, 32.30, 0.05);
  EXPECT_NEAR(b.a, 79.19, 0.15);
  EXPECT_NEAR(b.b, -107.86, 0.15);
  EXPECT_NEAR(r.hue_deg(), 40.0, 0.1);
  EXPECT_NEAR(b.hue_deg(), 306.3, 0.1);
  EXPECT_NEAR(r.chroma(), std::hypot(r.a, r.b), 1e-12);
  EXPECT_NEAR((xyz_to_srgb(srgb_to_xyz(Rgb(0.2, 0.5, 0.9))) - Rgb(0.2, 0.5, 0.9)).norm(), 0.0, 1e-12);
}

TEST(Colour, LabAndBradfordRoundTrip) {
  const Xyz x(0.31, 0.22, 0.57);
  for (const Xyz* w : {&d50(), &d65()}) {
    const Xyz back = lab_to_xyz(xyz_to_lab(x, *w), *w);
    EXPECT_NEAR((back - x).norm(), 0.0, 1e-9);
  }
  // The white adapts to the white; a colour adapts there and back unchanged.
  EXPECT_NEAR((adapt(d50(), d50(), d65()) - d65()).norm(), 0.0, 1e-6);
  EXPECT_NEAR((adapt(adapt(x, d50(), d65()), d65(), d50()) - x).norm(), 0.0, 1e-6);
  // D50 is ICC's white, as LittleCMS gives it.
  EXPECT_NEAR(d50().x(), 0.9642, 1e-4);
  EXPECT_NEAR(d50().z(), 0.8249, 1e-4);
  // A reflectance factor above 1 (near the specular direction) gives L* above 100.
  EXPECT_GT(srgb_to_lab(Rgb::Constant(1.5)).L, 100.0);
}
