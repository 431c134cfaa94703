// Image files named on the command line (core/input_files.h): folders expand to their
// images sorted by name, files are taken as they are, and every refusal names the option.
#include "paintlab/core/input_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
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

// Issue 13: a folder given as a rig or paint file said "key 'name': required key is
// missing", a symlink loop said "no such file", an unreadable file had no errno. Each now
// says what the path is, in the message every reader (TOML, JSON, EXR, images) gives.
TEST(InputFiles, ARequiredFileSaysWhatThePathIs) {
  test::TempDir d;
  const auto message = [](const std::filesystem::path& p) {
    try {
      require_readable_file(p);
    } catch (const IoError& e) {
      EXPECT_EQ(exit_code(e), kExitBadInput) << e.what();
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::filesystem::create_directory(d / "rig.toml");
  EXPECT_EQ(message(d / "rig.toml"), (d / "rig.toml").string() + ": is a folder, not a file");
  EXPECT_EQ(message(d / "absent.toml"), (d / "absent.toml").string() + ": no such file");
  std::filesystem::create_symlink(d / "loop-b", d / "loop-a");
  std::filesystem::create_symlink(d / "loop-a", d / "loop-b");
  EXPECT_EQ(message(d / "loop-a"), (d / "loop-a").string() + ": cannot be opened (Too many levels of symbolic links)");
  std::filesystem::create_symlink(d / "gone.toml", d / "dangling.toml");
  EXPECT_EQ(message(d / "dangling.toml"),
            (d / "dangling.toml").string() + ": is a symbolic link to " + (d / "gone.toml").string() +
                ", which does not exist");
  test::write_text(d / "ok.toml", "name = \"x\"\n");
  EXPECT_EQ(message(d / "ok.toml"), "no error");
  // Every reader says the same (a folder as a rig file is no longer a missing key).
  try {
    (void)ConfigTable::parse_file(d / "rig.toml");
    ADD_FAILURE() << "a folder parsed as TOML";
  } catch (const IoError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("rig.toml: is a folder, not a file"));
  }
  try {
    (void)read_json_file(d / "loop-a");
    ADD_FAILURE() << "a symlink loop parsed as JSON";
  } catch (const IoError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("Too many levels of symbolic links"));
  }
}

TEST(InputFiles, AnUnreadableFileGivesTheSystemsReason) {
  if (::geteuid() == 0)
    GTEST_SKIP() << "running as root: root reads a file without read permission, so none can be made here";
  test::TempDir d;
  test::write_text(d / "rig.toml", "name = \"x\"\n");
  std::filesystem::permissions(d / "rig.toml", std::filesystem::perms::none);
  try {
    require_readable_file(d / "rig.toml");
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()), (d / "rig.toml").string() + ": cannot be opened (Permission denied)");
  }
}
