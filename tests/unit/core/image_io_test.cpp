#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "paintlab/core/atomic_file.h"
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

// A damaged header that states a huge data window is a DataError naming the file, never an
// allocation of the stated size (fuzzing read_exr: such headers made reads allocate hundreds of MB).
TEST(ImageIo, ExrWithAHugeDataWindowIsADataErrorNotAnAllocation) {
  test::TempDir d;
  ExrImage img;
  img.add("Y", ImageF(4, 3, 1, 0.25f));
  write_exr(d / "small.exr", img);
  std::string bytes = read_file(d / "small.exr");
  // The attribute is "dataWindow\0box2i\0" + int32 size 16 + xmin, ymin, xmax, ymax.
  const std::string key("dataWindow\0box2i\0", 17);
  const std::size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  const auto damaged_with = [&](std::vector<std::pair<int, std::int32_t>> fields) {
    std::string damaged = bytes;
    for (const auto& [field, value] : fields)
      std::memcpy(damaged.data() + at + key.size() + 4 + 4 * field, &value, sizeof value);
    test::write_text(d / "damaged.exr", damaged);
    return d / "damaged.exr";
  };
  // Sides beyond kMaxExrSide (OpenEXR's own limit, set by read_exr), a window of 30000 x 30000
  // (within the sides, 9e8 values: read_exr's value bound, or OpenEXR's check of the line-offset
  // table, whichever the file reaches first), a window whose end lies before its start.
  for (const auto& fields : std::vector<std::vector<std::pair<int, std::int32_t>>>{
           {{3, 1 << 30}}, {{2, 29999}, {3, 29999}}, {{2, -5}}}) {
    try {
      (void)read_exr(damaged_with(fields));
      ADD_FAILURE() << "field " << fields[0].first << " = " << fields[0].second << " was read";
    } catch (const DataError& e) {
      EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("damaged.exr"));
    }
  }
}

// An attribute whose size word is damaged is refused before OpenEXR reads it: OpenEXR sizes a
// string attribute from that word, so a file of a few hundred bytes made it allocate and clear
// up to 2 GB (fuzzing read_exr: 25 runs a second, 2 GB peak). The message names the attribute.
TEST(ImageIo, ExrAttributeSizeBeyondTheFileIsADataErrorNamingTheAttribute) {
  test::TempDir d;
  ExrImage img;
  img.add("Y", ImageF(4, 3, 1, 0.25f));
  img.attributes["paintlab.angle_deg"] = "42";
  write_exr(d / "small.exr", img);
  const std::string bytes = read_file(d / "small.exr");
  const std::string key("paintlab.angle_deg\0string\0", 26);
  const std::size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  for (const std::int32_t size : {std::int32_t{0x7fffffff}, std::int32_t{-1}, static_cast<std::int32_t>(bytes.size())}) {
    std::string damaged = bytes;
    std::memcpy(damaged.data() + at + key.size(), &size, sizeof size);
    test::write_text(d / "damaged.exr", damaged);
    try {
      (void)read_exr(d / "damaged.exr");
      ADD_FAILURE() << "size " << size << " was read";
    } catch (const DataError& e) {
      EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("damaged.exr"));
      EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("'paintlab.angle_deg' (string) states"));
    }
  }
  // A name without its terminating zero within OpenEXR's 31 characters, and a cut file.
  std::string unterminated = bytes;
  std::fill(unterminated.begin() + static_cast<std::ptrdiff_t>(at),
            unterminated.begin() + static_cast<std::ptrdiff_t>(at + key.size()), 'x');
  test::write_text(d / "damaged.exr", unterminated);
  EXPECT_THROW((void)read_exr(d / "damaged.exr"), DataError);
  test::write_text(d / "damaged.exr", bytes.substr(0, at + 5));
  EXPECT_THROW((void)read_exr(d / "damaged.exr"), DataError);
  EXPECT_EQ(read_exr(d / "small.exr").attributes.at("paintlab.angle_deg"), "42");
}
