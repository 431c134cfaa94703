#pragma once
// What `paintlab calibrate response|dark|flat` and `paintlab hdr merge` share: an exposure
// stack from files (--images FILES|DIR with --exposures LIST or --exposure-file F). Captured
// stacks (--rig R --capture) come from acq::capture_stack.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::app {

struct StackInput {
  std::vector<std::string> images;  // files or folders
  std::string exposures;            // --exposures LIST
  std::string exposure_file;        // --exposure-file F
  int bit_depth = 0;                // --bit-depth (0: the files')
};

// Adds --images, --exposures, --exposure-file, --bit-depth to `cmd`.
void add_stack_options(CLI::App* cmd, StackInput* in);

// Loads the stack. Exposure times: --exposures, or --exposure-file, or (for a single folder)
// its exposures.txt. UsageError when both or neither are given or the counts differ;
// IoError/DataError naming the unreadable or inconsistent file.
calib::ExposureStack load_stack_input(const StackInput& in);

}  // namespace paintlab::app
