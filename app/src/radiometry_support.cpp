#include "radiometry_support.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/result.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "paintlab/sim/scenes.h"
#include "cli.h"

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

namespace {

void ask_technician(const std::string& text) {
  say(text + " and press Enter");
  std::string line;
  if (!std::getline(std::cin, line))
    throw UsageError("--capture on a real rig needs a technician at the keyboard (standard input is closed)");
}

// Frames of a fixed scene radiance through the simulated sensor, as the world's own source
// makes them (exposure, gain, output depth, the camera's black level).
sim::FrameSource static_scene(sim::SimRig& rig, std::shared_ptr<const ImageF> radiance) {
  sim::SimWorld* w = &rig.world();
  return [w, radiance](const sim::FrameRequest& r, std::uint16_t* out) {
    sim::ExposureSettings es;
    es.exposure_s = r.exposure_s;
    es.gain_db = r.gain_db;
    const int bits = dev::bit_depth(r.format);
    es.output_bits = bits;
    const Image<std::uint16_t> raw = w->sensor().expose(*radiance, es);
    const auto& sp = w->config().sensor;
    const double offset = (r.black_level - sp.black_level_dn) * std::ldexp(1.0, bits - sp.adc_bits);
    const double max = std::ldexp(1.0, bits) - 1.0;
    std::fill(out, out + static_cast<std::size_t>(r.width) * r.height, std::uint16_t{0});
    for (int y = 0; y < std::min(r.height, raw.height()); ++y)
      for (int x = 0; x < std::min(r.width, raw.width()); ++x)
        out[static_cast<std::size_t>(y) * r.width + x] =
            static_cast<std::uint16_t>(std::clamp(std::round(raw.at(x, y) + offset), 0.0, max));
  };
}

double quantile_of(const Image<std::uint16_t>& img, double q) {
  std::vector<std::uint16_t> v;
  const std::size_t stride = img.size() > 400000 ? 4 : 1;
  v.reserve(img.size() / stride + 1);
  for (std::size_t i = 0; i < img.size(); i += stride) v.push_back(img.values()[i]);
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

void present(RigDevices& d, LensView view) {
  if (d.sim && d.sim->camera()) {
    sim::SimRig& rig = *d.sim;
    switch (view) {
      case LensView::Scene:
        rig.camera()->set_source(rig.world_source());
        break;
      case LensView::Capped:
        rig.camera()->set_source(static_scene(rig, std::make_shared<ImageF>(sim::dark_field(rig.world().camera()))));
        break;
      case LensView::Diffuser: {
        // Bright enough that the image centre reaches half the full well in 10 ms.
        const sim::SimWorld& w = rig.world();
        const double g =
            w.sensor().electrons_per_s_per_radiance(w.camera().width() / 2, w.camera().height() / 2);
        const double level = 0.5 * w.config().sensor.full_well_e / (g * 0.01);
        rig.camera()->set_source(static_scene(rig, std::make_shared<ImageF>(sim::uniform_field(w.camera(), level))));
        break;
      }
    }
    return;
  }
  switch (view) {
    case LensView::Scene:
      ask_technician("Take the lens cap or diffuser off the lens");
      break;
    case LensView::Capped:
      ask_technician("Put the cap on the lens (dark frames)");
      break;
    case LensView::Diffuser:
      ask_technician("Put the diffuser over the lens, or a uniformly lit white target filling the view (flat field)");
      break;
  }
}

calib::ExposureStack capture_stack(RigDevices& d, double gain_db, const std::vector<double>& exposures_s, int repeats,
                                   bool light_on, const fs::path& save_dir) {
  dev::Camera& cam = *d.camera;
  const int bits = dev::bit_depth(value_or_throw(cam.pixel_format()));
  value_or_throw(cam.set_gain_db(gain_db));
  if (light_on) value_or_throw(d.light->on());
  else value_or_throw(d.light->off());
  calib::ExposureStack out;
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
        out.files.push_back(save_dir / name);
        out.exposures_s.push_back(f.meta.exposure_s);
        out.images.push_back(std::move(f.pixels));
      }
  } catch (...) {
    (void)d.light->off();
    throw;
  }
  value_or_throw(d.light->off());
  write_file_atomic(save_dir / "exposures.txt", listing);
  out.bit_depth = bits;
  spdlog::info("captured {} frames into {}", out.images.size(), save_dir.string());
  return out;
}

double find_exposure(RigDevices& d, double gain_db, double black_dn, double fill, double quantile, double start_s) {
  dev::Camera& cam = *d.camera;
  const int bits = dev::bit_depth(value_or_throw(cam.pixel_format()));
  value_or_throw(cam.set_gain_db(gain_db));
  const dev::ExposureRange range = value_or_throw(cam.exposure_range());
  const double full = std::ldexp(1.0, bits) - 1.0;
  double t = std::clamp(start_s, range.min_s, range.max_s);
  for (int it = 0; it < 12; ++it) {
    const double applied = value_or_throw(cam.set_exposure(t));
    const dev::Frame f = value_or_throw(cam.capture(std::max(5.0, 3.0 * applied + 2.0)));
    const double level = (quantile_of(f.pixels, quantile) - black_dn) / (full - black_dn);
    double next = level >= 0.97 ? applied / 8.0 : level < 1e-3 ? applied * 16.0 : applied * fill / level;
    next = std::clamp(next, range.min_s, range.max_s);
    if (level < 0.97 && std::abs(next / applied - 1.0) < 0.1) return applied;
    if (next == applied) return applied;  // at the end of the camera's range
    t = next;
  }
  return t;
}

}  // namespace paintlab::app
