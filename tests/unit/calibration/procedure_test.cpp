// The calibration procedure table (calibration/procedure.h): every step comes after the
// steps whose files it needs or uses, each file has one step, and the calibration folder's
// standard files follow the table.
#include "paintlab/calibration/procedure.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"

using namespace paintlab;
using ::testing::HasSubstr;

TEST(Procedure, EveryStepComesAfterWhatItNeedsAndUses) {
  std::set<std::string> written, names;
  for (const calib::ProcedureStep& s : calib::calibration_procedure()) {
    for (const std::string& f : s.needs) EXPECT_TRUE(written.count(f)) << s.name << " needs " << f << " before it is made";
    for (const std::string& f : s.uses) EXPECT_TRUE(written.count(f)) << s.name << " uses " << f << " before it is made";
    EXPECT_TRUE(written.insert(s.file).second) << s.file << " written by two steps";
    EXPECT_TRUE(names.insert(s.name).second) << s.name;
    EXPECT_FALSE(s.summary.empty()) << s.name;
    EXPECT_FALSE(s.shows.empty()) << s.name;
  }
  EXPECT_EQ(written.size(), 7u);
  // The radiometric steps come before every step that linearises with them.
  const auto& p = calib::calibration_procedure();
  EXPECT_EQ(p[1].name, "dark");
  EXPECT_EQ(p[2].name, "response");
  EXPECT_EQ(p[3].name, "flat");
}

TEST(Procedure, StandardFilesAndTheirStepsFollowTheTable) {
  const auto& files = calib::standard_files();
  const auto& steps = calib::calibration_procedure();
  ASSERT_EQ(files.size(), steps.size());
  for (std::size_t k = 0; k < files.size(); ++k) {
    EXPECT_EQ(files[k], steps[k].file);
    EXPECT_EQ(calib::calibrate_step_for(files[k]), steps[k].name);
  }
  EXPECT_EQ(calib::calibrate_step_for(calib::kCameraFile), "intrinsics");
  EXPECT_EQ(calib::calibrate_step_for("check.json"), "all");
  EXPECT_EQ(calib::procedure_step("light").needs, (std::vector<std::string>{calib::kCameraFile, calib::kSphereFile}));
  EXPECT_EQ(calib::procedure_step("light").angles, "-150:150:10");
  EXPECT_TRUE(calib::procedure_step("light").led);
  EXPECT_FALSE(calib::procedure_step("dark").led);
  try {
    calib::procedure_step("focus");
    FAIL() << "an unknown step was found";
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no calibration step 'focus'"));
    EXPECT_THAT(e.what(), HasSubstr("intrinsics, dark, response, flat, sphere, light, scale"));
  }
}
