// The outputs of a command against its inputs and the folders paintlab owns
// (fitting/output_guard.h): a session and a library are recognised by their files, an
// output inside either is refused naming the flag, the command's own library is not.
#include "paintlab/fitting/output_guard.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/error.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/paint_library.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

std::string guard_error(const fit::OutputGuard& g) {
  return test::error_message<UsageError>([&] { g.check(); });
}

}  // namespace

TEST(OutputGuard, SessionsAndLibrariesAreKnownByTheirFiles) {
  test::TempDir tmp;
  test::write_text(tmp / "session" / "session.json", "{}");
  test::write_text(tmp / "library" / fit::kLibraryIndexFile, R"({"format": "paintlab-library", "paints": []})");
  test::write_text(tmp / "other" / fit::kLibraryIndexFile, R"({"format": "something else"})");
  test::write_text(tmp / "broken" / fit::kLibraryIndexFile, "{not json");
  ASSERT_TRUE(fit::owned_folder_kind(tmp / "session"));
  EXPECT_EQ(fit::owned_folder_kind(tmp / "session")->what, "session folder");
  ASSERT_TRUE(fit::owned_folder_kind(tmp / "library"));
  EXPECT_EQ(fit::owned_folder_kind(tmp / "library")->what, "paint library");
  EXPECT_FALSE(fit::owned_folder_kind(tmp / "other"));
  EXPECT_FALSE(fit::owned_folder_kind(tmp / "broken"));
  EXPECT_FALSE(fit::owned_folder_kind(tmp.path()));
}

TEST(OutputGuard, AnOutputInsideASessionOrLibraryOrOverAnInputIsRefusedByItsFlag) {
  test::TempDir tmp;
  test::write_text(tmp / "session" / "session.json", "{}");
  test::write_text(tmp / "library" / fit::kLibraryIndexFile, R"({"format": "paintlab-library", "paints": []})");
  test::write_text(tmp / "fit.json", "{}");

  fit::OutputGuard into_session;
  into_session.input("SESSION", tmp / "session").output({"--out", tmp / "session" / "table.merl"});
  EXPECT_THAT(guard_error(into_session), HasSubstr("--out"));
  EXPECT_THAT(guard_error(into_session), HasSubstr("paintlab measure"));

  fit::OutputGuard over_input;
  over_input.input("INPUT", tmp / "fit.json").output({"--out", tmp / "fit.json"});
  EXPECT_THAT(guard_error(over_input), HasSubstr("--out"));

  fit::OutputGuard into_library;
  into_library.output({"--axf", tmp / "library" / "x.axf.h5"});
  EXPECT_THAT(guard_error(into_library), HasSubstr("paint library"));
  // The library the command owns (library add --dir) may be written.
  fit::OutputGuard owner;
  owner.output({"--dir", tmp / "library" / "x.axf.h5"}, tmp / "library");
  EXPECT_EQ(guard_error(owner), "(no error)");
  // Empty paths are left out.
  fit::OutputGuard empty;
  empty.input("--calib", "").output({"--hdr", ""});
  EXPECT_EQ(guard_error(empty), "(no error)");
}

// `check --images DIR` and `calibrate all --images DIR` read every file below DIR.
TEST(OutputGuard, EveryFileBelowAnEvidenceFolderIsAnInput) {
  test::TempDir tmp;
  test::write_text(tmp / "evidence" / "sphere" / "a.png", "x");
  test::write_text(tmp / "evidence" / "exposures.txt", "a.png 0.01\n");
  fit::OutputGuard deep;
  deep.input_tree("--images", tmp / "evidence").output({"--out", tmp / "evidence" / "sphere" / "a.png"});
  EXPECT_THAT(guard_error(deep), HasSubstr("--images"));
  fit::OutputGuard top;
  top.input_tree("--images", tmp / "evidence").output({"--out", tmp / "evidence" / "exposures.txt"});
  EXPECT_THAT(guard_error(top), HasSubstr("--images"));
  fit::OutputGuard beside;
  beside.input_tree("--images", tmp / "evidence").output({"--out", tmp / "evidence" / "new.json"});
  EXPECT_EQ(guard_error(beside), "(no error)");
  // No folder, or a file, adds nothing.
  fit::OutputGuard none;
  none.input_tree("--images", "").input_tree("--images", tmp / "missing").input_tree("--images", tmp / "evidence" / "exposures.txt");
  none.output({"--out", tmp / "evidence" / "exposures.txt"});
  EXPECT_EQ(guard_error(none), "(no error)");
}

TEST(OutputGuard, WhatAFitWasFittedToIsAnInputOfItsExport) {
  test::TempDir tmp;
  test::write_text(tmp / "fit.json", R"({"input": {"path": "/lab/s1/table.merl", "kind": "merl"}})");
  test::write_text(tmp / "one.json", R"({"input": {"path": "/lab/s1", "kind": "session"}})");
  test::write_text(tmp / "two.json", R"({"input": {"path": "/lab/s1", "kind": "sessions",
                                          "sessions": [{"path": "/lab/s1"}, {"path": "/lab/s2"}]}})");
  test::write_text(tmp / "old.json", R"({"parameters": {}})");
  test::write_text(tmp / "bad.json", "{not json");
  using Paths = std::vector<fs::path>;
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "fit.json"), Paths{"/lab/s1/table.merl"});
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "one.json"), Paths{"/lab/s1"});
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "two.json"), (Paths{"/lab/s1", "/lab/s2"}));  // every session fitted
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "old.json"), Paths{});
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "bad.json"), Paths{});      // export names the problem
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "paint.axf.h5"), Paths{});  // not a fit.json
  EXPECT_EQ(fit::fitted_inputs_of(tmp / "missing.json"), Paths{});
}
