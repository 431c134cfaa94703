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

// Exposure times from min to max whose successive ratios are not all equal (a geometric
// bracket times 1, 1.37, 1.71, 1, ...): a constant ratio leaves the response ambiguous.
std::vector<double> calibration_bracket(double min_s, double max_s, int count);

// True (and the ratio) when the sorted exposures step by one ratio within 2 %.
bool constant_ratio(std::vector<double> exposures_s, double* ratio);

}  // namespace paintlab::app
