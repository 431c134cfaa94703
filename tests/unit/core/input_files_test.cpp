// Image files named on the command line (core/input_files.h): folders expand to their
// images sorted by name, files are taken as they are, and every refusal names the option.
#include "paintlab/core/input_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(InputFiles, FoldersExpandToTheirImagesSortedAndFilesStayAsGiven) {
  test::TempDir tmp;
  for (const char* f : {"b.PNG", "a.png", "c.exr", "notes.txt", "d.jpg"}) test::write_text(tmp / "in" / f, "x");
  fs::create_directories(tmp / "in" / "sub.png");  // a folder, not an image
  test::write_text(tmp / "single.tif", "x");
  const auto raw =
      expand_input_files({(tmp / "in").string(), (tmp / "single.tif").string()}, "--images", kRawImageExtensions);
  ASSERT_EQ(raw.size(), 3u);
  EXPECT_EQ(raw[0].filename(), "a.png");
  EXPECT_EQ(raw[1].filename(), "b.PNG");  // extensions compare without case
  EXPECT_EQ(raw[2], tmp / "single.tif");
  const auto calib = expand_input_files({(tmp / "in").string()}, "--images", kCalibrationImageExtensions);
  ASSERT_EQ(calib.size(), 4u);
  EXPECT_EQ(calib[2].filename(), "c.exr");
  EXPECT_EQ(calib[3].filename(), "d.jpg");
}

TEST(InputFiles, RefusalsNameTheOptionAndTheArgument) {
  test::TempDir tmp;
  fs::create_directories(tmp / "empty");
  test::write_text(tmp / "txt" / "notes.txt", "x");
  auto message = [](const std::vector<std::string>& args) {
    try {
      expand_input_files(args, "--images", kRawImageExtensions);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(message({(tmp / "missing.png").string()}),
              HasSubstr("--images " + (tmp / "missing.png").string() + ": no such file or folder"));
  EXPECT_THAT(message({(tmp / "txt").string()}), HasSubstr("the folder holds no images (.png .tif .tiff .pgm)"));
  EXPECT_THAT(message({(tmp / "empty").string()}), HasSubstr("--images " + (tmp / "empty").string()));
  EXPECT_THAT(message({}), HasSubstr("--images: no images given"));
}
