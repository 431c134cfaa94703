#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "test_util.h"

using namespace paintlab;

TEST(ImageIo, ExrRoundTripKeepsChannelsAndAttributes) {
  test::TempDir d;
  ExrImage img;
  ImageF y(7, 5, 1), v(7, 5, 1);
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 7; ++c) {
      y.at(c, r) = 1e-4f * (r * 7 + c) + 3.5e3f * (c == 3);
      v.at(c, r) = 0.5f * c;
    }
  img.add("Y", y);
  img.add("var.Y", v);
  img.attributes["paintlab.angle_deg"] = "42";
  write_exr(d / "a.exr", img);
  ExrImage back = read_exr(d / "a.exr");
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.plane("Y").values(), y.values());
  EXPECT_EQ(back.plane("var.Y").values(), v.values());
  EXPECT_EQ(back.attributes.at("paintlab.angle_deg"), "42");
  EXPECT_THROW(back.plane("R"), DataError);
}

TEST(ImageIo, Png16RoundTrip) {
  test::TempDir d;
  Image<std::uint16_t> img(9, 4, 1);
  for (std::size_t i = 0; i < img.size(); ++i) img.values()[i] = static_cast<std::uint16_t>(i * 4000 % 65536);
  write_png(d / "a.png", img, 16);
  RawImage back = read_raw_image(d / "a.png");
  EXPECT_EQ(back.bit_depth, 16);
  EXPECT_EQ(back.pixels.values(), img.values());
}

TEST(ImageIo, BadFilesAreNamedErrors) {
  test::TempDir d;
  test::write_text(d / "x.exr", "not an exr");
  EXPECT_THROW(read_exr(d / "x.exr"), DataError);
  EXPECT_THROW(read_exr(d / "missing.exr"), IoError);
  test::write_text(d / "x.png", "not a png");
  EXPECT_THROW(read_raw_image(d / "x.png"), DataError);
}
