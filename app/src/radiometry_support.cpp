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
  return calib::load_stack_files(in.images, in.exposures, in.exposure_file, in.bit_depth);
}

}  // namespace paintlab::app
