#pragma once
// What `paintlab calibrate response|dark|flat` and `paintlab hdr merge` share: an exposure
// stack from files (--images FILES|DIR with --exposures LIST or --exposure-file F) or
// captured through the rig's camera (--rig R --capture), and what stands in front of the
// lens while it is captured.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "rig_devices.h"

namespace paintlab::app {

struct StackInput {
  std::vector<std::string> images;  // files or folders
  std::string exposures;            // --exposures LIST
  std::string exposure_file;        // --exposure-file F
  int bit_depth = 0;                // --bit-depth (0: the files')
};

// Adds --images, --exposures, --exposure-file, --bit-depth to `cmd`.
void add_stack_options(CLI::App* cmd, StackInput* in);

// Image files of `items`: files as given, folders expanded to their .png/.tif/.tiff/.pgm
// files sorted by name. UsageError when nothing is left.
std::vector<std::filesystem::path> expand_images(const std::vector<std::string>& items);

// Loads the stack. Exposure times: --exposures, or --exposure-file, or (for a single folder)
// its exposures.txt. UsageError when both or neither are given or the counts differ;
// IoError/DataError naming the unreadable or inconsistent file.
calib::ExposureStack load_stack_input(const StackInput& in);

// Exposure times from min to max whose successive ratios are not all equal (a geometric
// bracket times 1, 1.37, 1.71, 1, ...): a constant ratio leaves the response ambiguous.
std::vector<double> calibration_bracket(double min_s, double max_s, int count);

// True (and the ratio) when the sorted exposures step by one ratio within 2 %.
bool constant_ratio(std::vector<double> exposures_s, double* ratio);

// What is in front of the lens for a radiometric capture.
enum class LensView {
  Scene,     // nothing: the camera sees the rig
  Capped,    // the lens cap (dark frames)
  Diffuser,  // a uniform diffuser over the lens, or a uniformly lit white target filling the view (flat field)
};

// Puts `view` in front of the lens. On a simulated rig the simulator does it (the camera's
// frames show a dark field or a uniform field through the simulated sensor); on a real rig the
// technician does, prompted on the console (UsageError when standard input is closed).
void present(RigDevices& devices, LensView view);

// Captures `repeats` frames at each of `exposures_s` with the LED on or off (the table stays
// where it is), and saves them as PNG, with exposures.txt, in `save_dir`, which then works as
// `--images save_dir`. The stack holds the exposures the camera applied. DeviceError when a
// device fails.
calib::ExposureStack capture_stack(RigDevices& devices, double gain_db, const std::vector<double>& exposures_s,
                                   int repeats, bool light_on, const std::filesystem::path& save_dir);

// An exposure at which the `quantile` raw value lies near `fill` of the range above
// `black_dn` (LED as it is), found by a few trial frames from `start_s`; clamped to the
// camera's range.
double find_exposure(RigDevices& devices, double gain_db, double black_dn, double fill, double quantile,
                     double start_s);

}  // namespace paintlab::app
