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
#include "test_util.h"

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
  EXPECT_THAT(test::error_message<UsageError>([&] { calib::procedure_step("focus"); }),
              ::testing::AllOf(HasSubstr("no calibration step 'focus'"),
                               HasSubstr("intrinsics, dark, response, flat, sphere, light, scale")));
}

TEST(Procedure, AnglesAreAListOrARangeWithItsEndIncluded) {
  EXPECT_EQ(calib::parse_angles("90,270", "--angles"), (std::vector<double>{90, 270}));
  EXPECT_EQ(calib::parse_angles("-40,0,40.5", "--angles"), (std::vector<double>{-40, 0, 40.5}));
  const std::vector<double> range = calib::parse_angles("-150:150:10", "--angles");
  ASSERT_EQ(range.size(), 31u);
  EXPECT_DOUBLE_EQ(range.front(), -150.0);
  EXPECT_NEAR(range.back(), 150.0, 1e-9);
  EXPECT_EQ(calib::parse_angles("0:25:10", "--angles"), (std::vector<double>{0, 10, 20}));
  // Every step of the procedure parses.
  for (const calib::ProcedureStep& s : calib::calibration_procedure())
    if (!s.angles.empty()) {
      EXPECT_FALSE(calib::parse_angles(s.angles, s.name).empty()) << s.name;
    }
  const auto message = [](const std::string& text) {
    try {
      calib::parse_angles(text, "--angles");
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message("10,ten"), HasSubstr("--angles '10,ten': 'ten' is not a number of degrees"));
  EXPECT_THAT(message("0:10"), HasSubstr("expected START:STOP:STEP"));
  EXPECT_THAT(message("10:0:5"), HasSubstr("STOP >= START"));
  EXPECT_THAT(message("0:10:0"), HasSubstr("STEP > 0"));
  EXPECT_THAT(message("0:1e9:1e-3"), HasSubstr("more than 3600 angles"));
  EXPECT_THAT(message("nan"), HasSubstr("not a number"));
  EXPECT_THAT(message(""), HasSubstr("no angles given"));
}

TEST(Procedure, AStepWhoseInputsAreMissingNamesEachFileAndTheCommandThatMakesIt) {
  test::TempDir tmp;
  EXPECT_THAT(test::error_message<CalibrationError>([&] { calib::require_step_inputs(tmp.path(), "light", "/lab/rig.toml"); }),
              ::testing::AllOf(HasSubstr("calibrate light needs"),
                               HasSubstr("camera.json: run `paintlab calibrate intrinsics --rig /lab/rig.toml` first"),
                               HasSubstr("sphere.json: run `paintlab calibrate sphere --rig /lab/rig.toml` first")));
  test::write_text(tmp / calib::kCameraFile, "{}");
  test::write_text(tmp / calib::kSphereFile, "{}");
  EXPECT_NO_THROW(calib::require_step_inputs(tmp.path(), "light", "/lab/rig.toml"));
  EXPECT_NO_THROW(calib::require_step_inputs(tmp.path(), "intrinsics", "/lab/rig.toml"));  // needs nothing
}
