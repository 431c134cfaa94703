// The read side of a session folder (acquisition/session_reader.h): what bin, fit, export
// and render rely on before they touch a measurement.
#include "paintlab/acquisition/session_reader.h"
#include "paintlab/calibration/dark.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "sim_rigs.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using ::testing::HasSubstr;

namespace {

// A session planned at `planned` angles (0, 10, 20, ... deg) with the first `finished` of
// them finished: a small file per position, journalled with its checksum.
acq::SessionDir make_session(const fs::path& dir, int planned, int finished, const std::string& rig_file = "") {
  acq::SessionManifest m;
  m.sample = "panel 7";
  m.rig_file = rig_file;
  m.exposures_s = {0.01};
  for (int k = 0; k < planned; ++k) m.angles_deg.push_back(10.0 * k);
  const acq::SessionDir s = acq::SessionDir::create(dir, m);
  for (int k = 0; k < finished; ++k) {
    test::write_text(s.hdr_path(k), "image of position " + std::to_string(k));
    acq::JournalEntry e;
    e.index = k;
    e.angle_deg = e.angle_read_deg = 10.0 * k;
    e.file = acq::SessionDir::hdr_name(k);
    e.sha256 = sha256_file(s.hdr_path(k));
    s.journal().append(e);
  }
  return acq::SessionDir::open(dir);
}

}  // namespace

TEST(SessionReader, TellsSessionFoldersFromOtherPaths) {
  test::TempDir tmp;
  make_session(tmp / "s", 2, 2);
  EXPECT_TRUE(acq::is_session_dir(tmp / "s"));
  EXPECT_FALSE(acq::is_session_dir(tmp / "s" / "session.json"));  // the file, not the folder
  EXPECT_FALSE(acq::is_session_dir(tmp / "missing"));
  fs::create_directories(tmp / "empty");
  EXPECT_FALSE(acq::is_session_dir(tmp / "empty"));
  fs::create_directories(tmp / "odd" / "session.json");  // a folder of that name
  EXPECT_FALSE(acq::is_session_dir(tmp / "odd"));
}

TEST(SessionReader, CompleteSessionPassesAndAnIncompleteOneNamesWhatIsMissingAndHowToResume) {
  test::TempDir tmp;
  const acq::SessionDir done = make_session(tmp / "done", 3, 3);
  EXPECT_NO_THROW(acq::require_complete_session(done));

  const acq::SessionDir part = make_session(tmp / "part", 3, 1);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::require_complete_session(part); }),
              ::testing::AllOf(HasSubstr("2 of 3 light positions are missing (index 1, 2)"),
                               HasSubstr("paintlab measure --resume " + (tmp / "part").string())));

  // A finished file changed after it was journalled is not finished any more.
  test::write_text(done.hdr_path(1), "changed");
  EXPECT_THAT(test::error_message<DataError>([&] { acq::require_complete_session(done); }),
              HasSubstr("1 of 3 light positions are missing (index 1)"));

  // Long lists are cut after 8 indices.
  const acq::SessionDir empty = make_session(tmp / "none", 12, 0);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::require_complete_session(empty); }),
              HasSubstr("12 of 12 light positions are missing (index 0, 1, 2, 3, 4, 5, 6, 7, ...)"));
}

TEST(SessionReader, ChecksumCoversManifestAndJournalInThatOrder) {
  test::TempDir tmp;
  const acq::SessionDir s = make_session(tmp / "s", 3, 2);
  const std::string before = acq::session_sha256(s.dir());
  EXPECT_EQ(before, sha256_hex(read_file(s.dir() / "session.json") + read_file(s.dir() / "journal.jsonl")));
  EXPECT_EQ(before.size(), 64u);
  // Another finished position changes the identity of the measurement.
  test::write_text(s.hdr_path(2), "image of position 2");
  acq::JournalEntry e;
  e.index = 2;
  e.angle_deg = 20.0;
  e.file = acq::SessionDir::hdr_name(2);
  e.sha256 = sha256_file(s.hdr_path(2));
  s.journal().append(e);
  EXPECT_NE(acq::session_sha256(s.dir()), before);
}

TEST(SessionReader, CalibrationFromTheGivenFolderOrTheSessionsRigAndClearErrorsOtherwise) {
  test::TempDir tmp;
  // The rig file names its calibration folder (relative to the file).
  test::write_text(tmp / "rig" / "rig.toml", test::small_sim_rig());
  fs::create_directories(tmp / "rig" / "calib");
  calib::DarkFrame dark;
  dark.bias_dn = ImageF(4, 3, 1, 64.0f);
  dark.rate_dn_per_s = ImageF(4, 3, 1, 0.0f);
  dark.hot = ImageU8(4, 3, 1, 0);
  dark.bit_depth = 12;
  dark.save(tmp / "rig" / "calib" / calib::kDarkFile);
  const acq::SessionDir s = make_session(tmp / "s", 2, 2, (tmp / "rig" / "rig.toml").string());

  const calib::RigCalibration of_rig = acq::session_calibration(s, std::nullopt);
  EXPECT_TRUE(of_rig.has(calib::kDarkFile));
  ASSERT_TRUE(of_rig.dark());  // loaded as its type, with its map
  EXPECT_EQ(of_rig.dark()->width(), 4);
  EXPECT_EQ(fs::canonical(of_rig.dir()), fs::canonical(tmp / "rig" / "calib"));
  fs::create_directories(tmp / "other");
  const calib::RigCalibration given = acq::session_calibration(s, tmp / "other");
  EXPECT_FALSE(given.has(calib::kDarkFile));

  // A calibration file that does not parse is an error naming it, not an empty calibration.
  write_json_file(tmp / "rig" / "calib" / calib::kScaleFile, Json{{"note", "not a scale"}});
  EXPECT_THAT(test::error_message<Error>([&] { acq::session_calibration(s, std::nullopt); }),
              HasSubstr("scale.json"));
  EXPECT_THAT(test::error_message<IoError>([&] { acq::session_calibration(s, tmp / "nowhere"); }),
              ::testing::AllOf(HasSubstr("nowhere"), HasSubstr("no such calibration folder")));
  const acq::SessionDir orphan = make_session(tmp / "orphan", 1, 1, (tmp / "gone.toml").string());
  EXPECT_THAT(test::error_message<IoError>([&] { acq::session_calibration(orphan, std::nullopt); }),
              ::testing::AllOf(HasSubstr("gone.toml"), HasSubstr("--calib DIR")));
}
