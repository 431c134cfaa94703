#include "radiometry_support.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"
#include "cli.h"

namespace fs = std::filesystem;

namespace paintlab::app {

void add_stack_options(CLI::App* cmd, StackInput* in) {
  cmd->add_option("--images", in->images, "images (PNG, TIFF, PGM; 8 or 16 bit) or folders of them")->expected(1, -1);
  cmd->add_option("--exposures", in->exposures, "exposure times in seconds, comma-separated, in the order of the images");
  cmd->add_option("--exposure-file", in->exposure_file, "file of 'name time' lines (seconds) instead of --exposures");
  cmd->add_option("--bit-depth", in->bit_depth, "significant bits of the data: 8, 10, 12, 14 or 16 (default: the files')");
}

calib::ExposureStack load_stack_input(const StackInput& in) {
  const auto files = expand_input_files(in.images, "--images", kRawImageExtensions);
  std::vector<double> times;
  if (!in.exposures.empty() && !in.exposure_file.empty())
    throw UsageError("give either --exposures or --exposure-file, not both");
  if (!in.exposures.empty()) {
    times = calib::parse_exposure_list(in.exposures, "--exposures");
  } else if (!in.exposure_file.empty()) {
    times = calib::read_exposure_file(in.exposure_file, files);
  } else if (in.images.size() == 1 && fs::is_directory(in.images[0]) && fs::exists(fs::path(in.images[0]) / "exposures.txt")) {
    times = calib::read_exposure_file(fs::path(in.images[0]) / "exposures.txt", files);
  } else {
    throw UsageError("give the exposure times: --exposures LIST or --exposure-file F");
  }
  if (times.size() != files.size())
    throw UsageError(fmt::format("--exposures gives {} times for {} images: give one time per image, in the same order",
                                 times.size(), files.size()));
  return calib::load_exposure_stack(files, times, in.bit_depth);
}

}  // namespace paintlab::app
