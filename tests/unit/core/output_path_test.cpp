// Output paths checked before a command works (core/output_path.h, issue 13): an output is
// never an input (by name, relative or absolute, through a symlink or a hard link), never
// inside a protected folder, and its folder exists and is writable; every refusal is a
// UsageError naming the flag and both paths, and nothing is touched.
#include "paintlab/core/output_path.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

// The message check_output throws for `out`, or "" when it accepts it.
std::string output_refusal(const OutputSpec& out, const std::vector<InputSpec>& inputs,
                           const std::vector<ProtectedDir>& dirs = {}) {
  try {
    check_output(out, inputs, dirs);
  } catch (const UsageError& e) {
    return e.what();
  } catch (const IoError& e) {  // a folder that cannot be written (exit 1, not 2)
    EXPECT_EQ(exit_code(e), kExitFailed) << e.what();
    return e.what();
  }
  return "";
}

// Changes the working folder for one test and restores it.
class OutputPathCwd {
 public:
  explicit OutputPathCwd(const fs::path& dir) : old_(fs::current_path()) { fs::current_path(dir); }
  ~OutputPathCwd() { fs::current_path(old_); }

 private:
  fs::path old_;
};

}  // namespace

TEST(OutputPath, AnOutputThatIsAnInputIsRefusedNamingBoth) {
  test::TempDir tmp;
  test::write_text(tmp / "fit.json", "{}");
  const std::string m = output_refusal({"--axf", tmp / "fit.json"}, {{"INPUT", tmp / "fit.json"}});
  EXPECT_EQ(m, "--axf " + (tmp / "fit.json").string() + " is the input " + (tmp / "fit.json").string() +
                   "; choose another file name");
  // A flag's input is named with its flag.
  EXPECT_THAT(output_refusal({"--out", tmp / "fit.json"}, {{"--dark", tmp / "fit.json"}}),
              HasSubstr("is the input --dark " + (tmp / "fit.json").string()));
  // An input the command found elsewhere is named with where it came from.
  EXPECT_THAT(output_refusal({"--merl", tmp / "fit.json"}, {{"what f.json was fitted to", tmp / "fit.json"}}),
              HasSubstr("is the input " + (tmp / "fit.json").string() + " (what f.json was fitted to)"));
  // Another file in the same folder is fine; so is an input that does not exist.
  EXPECT_EQ(output_refusal({"--axf", tmp / "fit.axf.h5"}, {{"INPUT", tmp / "fit.json"}}), "");
  EXPECT_EQ(output_refusal({"--axf", tmp / "new.json"}, {{"INPUT", tmp / "other.json"}}), "");
  // The output does not exist yet and equals an input that does not either: still refused.
  EXPECT_THAT(output_refusal({"--out", tmp / "a" / ".." / "new.json"}, {{"INPUT", tmp / "new.json"}}),
              HasSubstr("is the input"));
}

TEST(OutputPath, RelativeAndAbsoluteSpellingsOfOneFileAreTheSameFile) {
  test::TempDir tmp;
  test::write_text(tmp / "sub" / "x.axf.h5", "paint");
  const OutputPathCwd cwd(tmp.path());
  EXPECT_THAT(output_refusal({"--out", "sub/x.axf.h5"}, {{"PAINT", tmp / "sub" / "x.axf.h5"}}),
              HasSubstr("--out sub/x.axf.h5 is the input " + (tmp / "sub" / "x.axf.h5").string()));
  EXPECT_THAT(output_refusal({"--out", tmp / "sub" / "x.axf.h5"}, {{"PAINT", "./sub/../sub/x.axf.h5"}}),
              HasSubstr("is the input ./sub/../sub/x.axf.h5"));
  // Not yet existing, relative against absolute.
  EXPECT_THAT(output_refusal({"--out", "new.png"}, {{"PAINT", tmp / "new.png"}}), HasSubstr("is the input"));
  EXPECT_EQ(output_refusal({"--out", "sub/y.png"}, {{"PAINT", tmp / "sub" / "x.axf.h5"}}), "");
}

TEST(OutputPath, ASymlinkOrHardLinkToAnInputIsTheInput) {
  test::TempDir tmp;
  test::write_text(tmp / "data" / "table.binary", "measured");
  fs::create_symlink(tmp / "data" / "table.binary", tmp / "link.binary");
  std::string m = output_refusal({"--merl", tmp / "link.binary"}, {{"INPUT", tmp / "data" / "table.binary"}});
  EXPECT_THAT(m, HasSubstr("--merl " + (tmp / "link.binary").string() + " is the same file as the input " +
                           (tmp / "data" / "table.binary").string() + " (through a symlink or hard link)"));
  // The input given through the link, the output by its real name.
  EXPECT_THAT(output_refusal({"--merl", tmp / "data" / "table.binary"}, {{"INPUT", tmp / "link.binary"}}),
              HasSubstr("same file as the input " + (tmp / "link.binary").string()));
  // A folder reached through a symlink: the output does not exist yet.
  fs::create_directory_symlink(tmp / "data", tmp / "alias");
  EXPECT_THAT(output_refusal({"--out", tmp / "alias" / "new.json"}, {{"INPUT", tmp / "data" / "new.json"}}),
              HasSubstr("same file as the input"));
  // A hard link: another name of the same inode.
  fs::create_hard_link(tmp / "data" / "table.binary", tmp / "hard.binary");
  m = output_refusal({"--out", tmp / "hard.binary"}, {{"INPUT", tmp / "data" / "table.binary"}});
  EXPECT_THAT(m, HasSubstr("is the same file as the input " + (tmp / "data" / "table.binary").string()));
  // A copy is another file.
  fs::copy_file(tmp / "data" / "table.binary", tmp / "copy.binary");
  EXPECT_EQ(output_refusal({"--out", tmp / "copy.binary"}, {{"INPUT", tmp / "data" / "table.binary"}}), "");
}

TEST(OutputPath, AnOutputInsideAProtectedFolderIsRefused) {
  test::TempDir tmp;
  test::write_text(tmp / "S" / "session.json", "{}");
  test::write_text(tmp / "S" / "hdr" / "pos_003.exr", "exr");
  const ProtectedDir session{tmp / "S", "session folder", "a measurement session is only written by `paintlab measure`"};
  EXPECT_EQ(output_refusal({"--out", tmp / "S" / "session.json"}, {{"SESSION", tmp / "S"}}, {session}),
            "--out " + (tmp / "S" / "session.json").string() + " is inside the session folder " +
                (tmp / "S").string() + " (a measurement session is only written by `paintlab measure`)");
  EXPECT_THAT(output_refusal({"--merl", tmp / "S" / "hdr" / "new.binary"}, {}, {session}),
              HasSubstr("is inside the session folder"));
  // Through a symlink to a folder inside the session.
  fs::create_directory_symlink(tmp / "S" / "hdr", tmp / "frames");
  EXPECT_THAT(output_refusal({"--out", tmp / "frames" / "x.exr"}, {}, {session}), HasSubstr("is inside the session"));
  // The folder itself (a folder output).
  OutputSpec dir{"--folder", tmp / "S"};
  dir.folder = true;
  EXPECT_THAT(output_refusal(dir, {}, {session}), HasSubstr("--folder " + (tmp / "S").string() + " is the session folder"));
  // Beside it is fine ("S2" shares the prefix but is another folder).
  EXPECT_EQ(output_refusal({"--out", tmp / "S2.json"}, {}, {session}), "");
  fs::create_directory(tmp / "S2");
  EXPECT_EQ(output_refusal({"--out", tmp / "S2" / "fit.json"}, {}, {session}), "");
}

TEST(OutputPath, FilesWrittenBesideAnOutputAreNamedWithWhatTheUserTyped) {
  test::TempDir tmp;
  test::write_text(tmp / "frames" / "x.exr", "image");
  OutputSpec side{"--out", tmp / "frames" / "x.exr"};
  side.beside = tmp / "frames" / "x.json";
  EXPECT_EQ(output_refusal(side, {{"--images", tmp / "frames" / "x.exr"}}),
            "--out " + (tmp / "frames" / "x.json").string() + " also writes " + (tmp / "frames" / "x.exr").string() +
                ", which is the input --images " + (tmp / "frames" / "x.exr").string() + "; choose another file name");
}

TEST(OutputPath, AFolderOutputThatHoldsAnInputIsRefused) {
  test::TempDir tmp;
  test::write_text(tmp / "demo" / "paint.toml", "x");
  OutputSpec out{"--out", tmp / "demo"};
  out.folder = true;
  EXPECT_THAT(output_refusal(out, {{"--paint", tmp / "demo" / "paint.toml"}}),
              HasSubstr("--out " + (tmp / "demo").string() + " holds the input --paint"));
  EXPECT_EQ(output_refusal(out, {{"--paint", tmp / "paint.toml"}}), "");
}

TEST(OutputPath, TheOutputFolderMustExistUnlessTheCommandCreatesIt) {
  test::TempDir tmp;
  const fs::path out = tmp / "missing" / "fit.json";
  EXPECT_EQ(output_refusal({"--out", out}, {}),
            "--out " + out.string() + ": the folder " + (tmp / "missing").string() + " does not exist (create it first)");
  OutputSpec created{"--out", tmp / "missing" / "deeper" / "merged.exr"};
  created.create_parents = true;
  EXPECT_EQ(output_refusal(created, {}), "");
  // A file where the folder should be.
  test::write_text(tmp / "plain", "x");
  EXPECT_THAT(output_refusal({"--out", tmp / "plain" / "fit.json"}, {}), HasSubstr("is not a folder"));
  created.path = tmp / "plain" / "a" / "b.exr";
  EXPECT_THAT(output_refusal(created, {}), HasSubstr((tmp / "plain").string() + " is not a folder"));
  // A folder where a file is written.
  fs::create_directory(tmp / "dir.json");
  EXPECT_THAT(output_refusal({"--out", tmp / "dir.json"}, {}), HasSubstr("is a folder; give the name of a file"));
  // A bare file name goes in the working folder.
  const OutputPathCwd cwd(tmp.path());
  EXPECT_EQ(output_refusal({"--out", "fit.json"}, {}), "");
}

TEST(OutputPath, AnOutputFolderThatIsNotWritableIsRefused) {
  if (::geteuid() == 0)
    GTEST_SKIP() << "running as root: root may write into a folder without write permission, so a read-only "
                    "folder cannot be made here (the check uses access(W_OK))";
  test::TempDir tmp;
  fs::create_directory(tmp / "ro");
  fs::permissions(tmp / "ro", fs::perms::owner_read | fs::perms::owner_exec);
  const std::string m = output_refusal({"--out", tmp / "ro" / "fit.json"}, {});
  fs::permissions(tmp / "ro", fs::perms::owner_all);
  EXPECT_THAT(m, HasSubstr("--out " + (tmp / "ro" / "fit.json").string() + ": the folder " + (tmp / "ro").string() +
                           " is not writable"));
}

TEST(OutputPath, TwoOutputsOfOneCommandMustDiffer) {
  test::TempDir tmp;
  const std::vector<OutputSpec> outs = {{"--out", tmp / "t.binary"}, {"--coverage", tmp / "." / "t.binary"}};
  try {
    check_outputs_distinct(outs);
    ADD_FAILURE() << "two outputs on one file were accepted";
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--coverage " + (tmp / "." / "t.binary").string() + " is the same file as --out " +
                                    (tmp / "t.binary").string()));
  }
  const std::vector<OutputSpec> fine = {{"--out", tmp / "t.binary"}, {"--coverage", tmp / "t.coverage.exr"}};
  EXPECT_NO_THROW(check_outputs_distinct(fine));
}

TEST(OutputPath, ProtectedAncestorsAreFoundAsTypedAndThroughSymlinks) {
  test::TempDir tmp;
  test::write_text(tmp / "lib" / "index.json", "{}");
  fs::create_directories(tmp / "lib" / "sub");
  fs::create_directory_symlink(tmp / "lib" / "sub", tmp / "shortcut");
  auto classify = [](const fs::path& d) -> std::optional<ProtectedDir> {
    if (fs::exists(d / "index.json")) return ProtectedDir{d, "paint library", ""};
    return std::nullopt;
  };
  auto found = protected_ancestors(tmp / "lib" / "sub" / "x.h5", classify);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].path, tmp / "lib");  // as typed
  found = protected_ancestors(tmp / "shortcut" / "x.h5", classify);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_TRUE(fs::equivalent(found[0].path, tmp / "lib"));
  EXPECT_EQ(output_refusal({"--h5", tmp / "shortcut" / "x.h5"}, {}, found),
            "--h5 " + (tmp / "shortcut" / "x.h5").string() + " is inside the paint library " +
                found[0].path.string());
  {
    const OutputPathCwd cwd(tmp.path());
    found = protected_ancestors("lib/index.json", classify);
    ASSERT_EQ(found.size(), 1u);
    EXPECT_EQ(found[0].path, "lib");  // named as the user wrote it
  }
  EXPECT_TRUE(protected_ancestors(tmp / "elsewhere" / "x.h5", classify).empty());
  EXPECT_TRUE(path_is_within(tmp / "lib" / "a", tmp / "lib"));
  EXPECT_TRUE(path_is_within(tmp / "lib", tmp / "lib/"));
  EXPECT_FALSE(path_is_within(tmp / "library", tmp / "lib"));
}
