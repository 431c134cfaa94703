#pragma once
// The rig's calibration procedure as one table (docs/calibration.md "The procedure"): each
// step, the file it writes, the files it needs before it can run, what the stage shows the
// camera, whether the LED is lit and at which table angles it captures. `paintlab calibrate
// all` runs the steps in this order, each `paintlab calibrate STEP` and `paintlab check`
// name them from here, and the calibration folder's standard files are listed in this order.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace paintlab::calib {

struct ProcedureStep {
  std::string name;                 // `paintlab calibrate NAME`
  std::string file;                 // what it writes in the calibration folder (record.h names)
  std::vector<std::string> needs;   // files that must exist before it runs
  std::vector<std::string> uses;    // files it uses when they exist (linearisation, dark subtraction)
  std::string shows;                // what stands in front of the camera while it captures
  bool led = false;                 // the LED is lit while it captures
  std::string angles;               // table angles it captures at: "a,b,c" or "START:STOP:STEP" (deg); empty: the table stays
  std::string summary;              // one line for --help
};

// intrinsics, dark, response, flat, sphere, light, scale: every step after the ones it needs.
const std::vector<ProcedureStep>& calibration_procedure();

// The step called `name`; UsageError listing the steps for another name.
const ProcedureStep& procedure_step(std::string_view name);

// Table angles in degrees from "a,b,c" or "START:STOP:STEP" (STOP included when the steps
// reach it), the form of ProcedureStep::angles and of --angles. UsageError naming `option`,
// the text and the bad part.
std::vector<double> parse_angles(const std::string& text, const std::string& option);

// CalibrationError naming each file step `step` needs (ProcedureStep::needs) that
// `calibration_dir` lacks, and the command that makes it for the rig file `rig_file`.
void require_step_inputs(const std::filesystem::path& calibration_dir, const std::string& step,
                         const std::filesystem::path& rig_file);

}  // namespace paintlab::calib
