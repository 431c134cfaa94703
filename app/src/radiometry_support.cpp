#include "radiometry_support.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/result.h"
#include "rig_devices.h"

namespace fs = std::filesystem;

namespace paintlab::app {

void add_stack_options(CLI::App* cmd, StackInput* in) {
  cmd->add_option("--images", in->images, "images (PNG, TIFF, PGM; 8 or 16 bit) or folders of them")->expected(1, -1);
  cmd->add_option("--exposures", in->exposures, "exposure times in seconds, comma-separated, in the order of the images");
  cmd->add_option("--exposure-file", in->exposure_file, "file of 'name time' lines (seconds) instead of --exposures");
  cmd->add_option("--bit-depth", in->bit_depth, "significant bits of the data: 8, 10, 12, 14 or 16 (default: the files')");
}

std::vector<fs::path> expand_images(const std::vector<std::string>& items) {
  std::vector<fs::path> out;
  for (const auto& item : items) {
    const fs::path p(item);
    if (fs::is_directory(p)) {
      std::vector<fs::path> found;
      for (const auto& e : fs::directory_iterator(p)) {
        std::string ext = e.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
        if (e.is_regular_file() && (ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".pgm"))
          found.push_back(e.path());
      }
      std::sort(found.begin(), found.end());
      if (found.empty()) throw UsageError("--images: folder " + item + " holds no PNG, TIFF or PGM image");
      out.insert(out.end(), found.begin(), found.end());
    } else {
      out.push_back(p);
    }
  }
  if (out.empty()) throw UsageError("--images: no images given");
  return out;
}

calib::ExposureStack load_stack_input(const StackInput& in) {
  const auto files = expand_images(in.images);
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

std::vector<double> calibration_bracket(double min_s, double max_s, int count) {
  if (!(min_s > 0.0) || !(max_s > min_s) || count < 3)
    throw UsageError(fmt::format("calibration bracket: need 0 < min < max and >= 3 exposures (got {} s, {} s, {})",
                                 min_s, max_s, count));
  std::vector<double> t(static_cast<std::size_t>(count));
  const double span = std::log(max_s / min_s);
  const double jitter[3] = {0.0, 0.3, -0.3};  // fractions of a step: ratios differ step to step
  for (int i = 0; i < count; ++i) {
    double x = (i + (i == 0 || i == count - 1 ? 0.0 : jitter[i % 3])) / (count - 1);
    t[static_cast<std::size_t>(i)] = min_s * std::exp(span * std::clamp(x, 0.0, 1.0));
  }
  return t;
}

bool constant_ratio(std::vector<double> t, double* ratio) {
  std::sort(t.begin(), t.end());
  if (t.size() < 3) return false;
  const double r0 = t[1] / t[0];
  for (std::size_t i = 2; i < t.size(); ++i)
    if (std::abs(t[i] / t[i - 1] / r0 - 1.0) > 0.02) return false;
  if (ratio) *ratio = r0;
  return true;
}

CapturedStack capture_stack(const RigConfig& rig, const std::vector<double>& exposures_s, int repeats, bool light_on,
                            const fs::path& save_dir) {
  OpenDevicesOptions which;
  which.turntable = false;
  RigDevices d = open_rig_devices(rig, which);
  dev::Camera& cam = *d.camera;
  const int bits = dev::bit_depth(value_or_throw(cam.pixel_format()));
  value_or_throw(cam.set_gain_db(rig.plan.gain_db));
  if (light_on) value_or_throw(d.light->on());
  else value_or_throw(d.light->off());
  CapturedStack out;
  out.devices["camera"] = cam.serial();
  fs::create_directories(save_dir);
  std::string listing = "# name exposure_s (applied, read back from the camera)\n";
  try {
    int index = 0;
    for (double t : exposures_s)
      for (int r = 0; r < repeats; ++r) {
        const double applied = value_or_throw(cam.set_exposure(t));
        dev::Frame f = value_or_throw(cam.capture(std::max(5.0, 3.0 * applied + 2.0)));
        const std::string name = fmt::format("{:03d}.png", index++);
        write_png(save_dir / name, f.pixels, bits <= 8 ? 8 : 16);
        listing += fmt::format("{} {:.9g}\n", name, f.meta.exposure_s);
        out.stack.files.push_back(save_dir / name);
        out.stack.exposures_s.push_back(f.meta.exposure_s);
        out.stack.images.push_back(std::move(f.pixels));
      }
  } catch (...) {
    (void)d.light->off();
    throw;
  }
  value_or_throw(d.light->off());
  write_file_atomic(save_dir / "exposures.txt", listing);
  out.stack.bit_depth = bits;
  spdlog::info("captured {} frames into {}", out.stack.images.size(), save_dir.string());
  return out;
}

}  // namespace paintlab::app
