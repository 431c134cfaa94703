#include "calibrate_support.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <iostream>
#include <regex>

#include "cli.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image_io.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "paintlab/sim/scenes.h"

namespace fs = std::filesystem;

namespace paintlab::app {

const char* to_string(Target t) {
  switch (t) {
    case Target::Sample:
      return "the sample sphere";
    case Target::WhiteReference:
      return "the white reference sphere";
    case Target::GlossySphere:
      return "the glossy calibration sphere";
  }
  return "?";
}

namespace {

// A technician at the keyboard: says what to put where and waits for Enter.
class ConsoleStage final : public Stage {
 public:
  void show_board(int index, int count, const calib::BoardSpec& board) override {
    prompt(fmt::format("Hold the {}x{} chessboard in view {} of {} (whole board visible, a different tilt each time) "
                       "and press Enter",
                       board.cols, board.rows, index + 1, count));
  }
  void mount(Target target) override {
    if (target == current_) return;
    prompt(fmt::format("Put {} on the holder and press Enter", to_string(target)));
    current_ = target;
  }

 private:
  static void prompt(const std::string& text) {
    say(text);
    std::string line;
    if (!std::getline(std::cin, line))
      throw UsageError("--capture on a real rig needs a technician at the keyboard (standard input is closed)");
  }
  Target current_ = Target::Sample;
};

sim::SimPaint glossy_sphere_paint() {
  brdf::CtLobe lobe;
  lobe.ks = brdf::Rgb(0.6, 0.6, 0.6);
  lobe.m = 0.03;
  lobe.r = 0.05;
  sim::SimPaint p;
  p.brdf = std::make_shared<brdf::CookTorrance>(brdf::Rgb(0.01, 0.01, 0.01), std::vector<brdf::CtLobe>{lobe});
  return p;
}

// The simulator plays the technician: it swaps the sphere's paint and shows chessboards
// to the simulated camera (which still reaches us through the GigE Vision driver).
class SimStage final : public Stage {
 public:
  SimStage(sim::SimRig& rig, double albedo) : rig_(rig), albedo_(albedo > 0 ? albedo : 0.99), sample_(rig.world().paint()) {}

  void show_board(int index, int count, const calib::BoardSpec& board) override {
    sim::SimWorld& w = rig_.world();
    sim::Chessboard cb;
    cb.cols = board.cols;
    cb.rows = board.rows;
    cb.square_m = board.square_m;
    if (poses_.size() != static_cast<std::size_t>(count) || board_cols_ != board.cols)
      poses_ = sim::chessboard_poses(w.camera(), cb, count, w.config().seed);
    board_cols_ = board.cols;
    // Lit so that white reaches half the full well in 10 ms at the image centre.
    const double g = w.sensor().electrons_per_s_per_radiance(w.camera().width() / 2, w.camera().height() / 2);
    sim::PlaneLighting light;
    light.irradiance_w_m2 = 0.5 * w.config().sensor.full_well_e / (g * 0.01) * kPi / cb.white_albedo;
    auto radiance = std::make_shared<ImageF>(
        sim::render_chessboard(w.camera(), cb, poses_[static_cast<std::size_t>(index)], light, 16, 1, 0));
    sim::SimWorld* wp = &w;
    rig_.camera()->set_source([wp, radiance](const sim::FrameRequest& r, std::uint16_t* out) {
      sim::ExposureSettings es;
      es.exposure_s = r.exposure_s;
      es.gain_db = r.gain_db;
      const int bits = dev::bit_depth(r.format);
      es.output_bits = bits;
      Image<std::uint16_t> raw = wp->sensor().expose(*radiance, es);
      const auto& sp = wp->config().sensor;
      const double offset = (r.black_level - sp.black_level_dn) * std::ldexp(1.0, bits - sp.adc_bits);
      const double max = std::ldexp(1.0, bits) - 1.0;
      std::fill(out, out + static_cast<std::size_t>(r.width) * r.height, std::uint16_t{0});
      for (int y = 0; y < std::min(r.height, raw.height()); ++y)
        for (int x = 0; x < std::min(r.width, raw.width()); ++x)
          out[static_cast<std::size_t>(y) * r.width + x] =
              static_cast<std::uint16_t>(std::clamp(std::round(raw.at(x, y) + offset), 0.0, max));
    });
    board_shown_ = true;
  }

  void mount(Target target) override {
    if (board_shown_) {
      rig_.camera()->set_source(rig_.world_source());
      board_shown_ = false;
    }
    switch (target) {
      case Target::Sample:
        rig_.world().set_paint(sample_);
        break;
      case Target::WhiteReference:
        rig_.world().set_paint(sim::reference_paint(albedo_));
        break;
      case Target::GlossySphere:
        rig_.world().set_paint(glossy_sphere_paint());
        break;
    }
  }
  double known_albedo() const override { return albedo_; }

 private:
  sim::SimRig& rig_;
  double albedo_;
  sim::SimPaint sample_;
  std::vector<Rigid3> poses_;
  int board_cols_ = 0;
  bool board_shown_ = false;
};

double quantile_of(const Image<std::uint16_t>& img, double q) {
  std::vector<std::uint16_t> v;
  const std::size_t stride = q >= 0.9999 ? 1 : 4;  // the top of the range: every pixel counts
  v.reserve(img.size() / stride + 1);
  for (std::size_t i = 0; i < img.size(); i += stride) v.push_back(img.values()[i]);
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// A merger for the radiometric calibration and the frame geometry. Building one tabulates
// the response and noise at every raw value, which costs more than merging a frame, so the
// shots of a step share it; a recalibrated response/dark/flat (other provenance: date and
// input checksums) or another geometry builds a new one.
const acq::HdrMerger& merger_for(const acq::HdrCalibration& hdr, int width, int height, int bit_depth) {
  struct Cache {
    std::string key;
    std::unique_ptr<acq::HdrMerger> merger;
  };
  static Cache cache;
  std::string key = fmt::format("{}x{}x{}", width, height, bit_depth);
  key += hdr.response ? hdr.response->provenance.to_json().dump() : "-";
  key += hdr.dark ? hdr.dark->provenance.to_json().dump() : "-";
  key += hdr.flat ? hdr.flat->provenance.to_json().dump() : "-";
  if (!cache.merger || cache.key != key) {
    cache.merger = std::make_unique<acq::HdrMerger>(hdr, acq::HdrOptions{}, width, height, 1, bit_depth);
    cache.key = std::move(key);
  }
  return *cache.merger;
}

// Linear DN/s of one frame, and the clipped pixels.
void linearise(const acq::HdrCalibration& hdr, Shot* s) {
  const Image<std::uint16_t>& raw = s->raw;
  const acq::HdrMerger& m = merger_for(hdr, raw.width(), raw.height(), s->bit_depth);
  calib::StackFrame f{&raw, s->exposure_s};
  acq::HdrResult r = m.merge(std::span<const calib::StackFrame>(&f, 1));
  s->rate = r.image.plane(r.image.names.front());
  const double full = std::ldexp(1.0, s->bit_depth) - 1.0;
  const double sat = std::min(m.window().saturation_dn, 0.995 * full);
  s->saturated = Image<std::uint8_t>(raw.width(), raw.height(), 1, 0);
  for (std::size_t i = 0; i < raw.size(); ++i) s->saturated.values()[i] = raw.values()[i] >= sat ? 1 : 0;
}

Image<std::uint16_t> to_mono(const Image<std::uint16_t>& img) {
  if (img.channels() == 1) return img;
  Image<std::uint16_t> out(img.width(), img.height(), 1);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      unsigned s = 0;
      for (int c = 0; c < img.channels(); ++c) s += img.at(x, y, c);
      out.at(x, y) = static_cast<std::uint16_t>((s + img.channels() / 2) / img.channels());
    }
  return out;
}

}  // namespace

acq::HdrCalibration load_radiometry(const RigConfig& rig) {
  acq::HdrCalibration h;
  const fs::path dir = rig.calibration_dir;
  if (fs::exists(dir / calib::kResponseFile)) h.response = calib::ResponseCurve::load(dir / calib::kResponseFile);
  if (fs::exists(dir / calib::kDarkFile)) h.dark = calib::DarkFrame::load(dir / calib::kDarkFile);
  if (fs::exists(dir / calib::kFlatFile)) h.flat = calib::FlatField::load(dir / calib::kFlatFile);
  return h;
}

Json device_serials(RigDevices& d, const RigConfig& rig) {
  // The camera's serial number; the turntable and LED have none over their protocols, so
  // their kind and address stand for them (not for simulated peers, whose ports change).
  Json j = Json::object();
  if (d.camera) j["camera"] = d.camera->serial();
  if (d.turntable && rig.turntable.kind != "sim") j["turntable"] = d.turntable->id();
  if (d.light && rig.light.kind != "sim") j["light"] = d.light->id();
  return j;
}

CalibSession open_calib_session(const RigConfig& rig, double albedo) {
  CalibSession s;
  s.rig = rig;
  s.devices = std::make_unique<RigDevices>(open_rig_devices(rig));
  if (s.devices->sim)
    s.stage = std::make_unique<SimStage>(*s.devices->sim, albedo);
  else
    s.stage = std::make_unique<ConsoleStage>();
  s.hdr = load_radiometry(rig);
  s.serials = device_serials(*s.devices, rig);
  s.bit_depth = dev::bit_depth(value_or_throw(s.camera().pixel_format()));
  value_or_throw(s.camera().set_gain_db(rig.plan.gain_db));
  return s;
}

Shot capture_shot(CalibSession& s, const std::string& step, const std::string& name, std::optional<double> angle_deg,
                  bool led_on, double fill, double quantile, std::optional<double> exposure_s) {
  RigDevices& d = *s.devices;
  if (angle_deg) {
    value_or_throw(d.turntable->move_to(wrap_360(*angle_deg)));
    value_or_throw(d.turntable->wait_settled(120.0));
    if (s.rig.plan.settle_s > 0) d.clock->sleep_s(s.rig.plan.settle_s);
  }
  if (led_on)
    value_or_throw(d.light->on());
  else
    value_or_throw(d.light->off());
  dev::Camera& cam = s.camera();
  const dev::ExposureRange range = value_or_throw(cam.exposure_range());
  const double full = std::ldexp(1.0, s.bit_depth) - 1.0;
  const double black = s.hdr.dark ? s.hdr.dark->mean_bias_dn : 0.0;
  // The search starts from the exposure the step's previous shot ended with (consecutive
  // shots of a step see the same target and light): usually one frame is enough.
  const std::string exposure_key = fmt::format("{}/{}", step, led_on ? "on" : "off");
  const auto previous = s.last_exposure_s.find(exposure_key);
  double t = std::clamp(previous != s.last_exposure_s.end() ? previous->second : 0.01, range.min_s, range.max_s);
  dev::Frame frame;
  if (exposure_s) {
    value_or_throw(cam.set_exposure(*exposure_s));
    frame = value_or_throw(cam.capture(10.0 + 2.0 * *exposure_s));
  }
  for (int it = 0; it < 12 && !exposure_s; ++it) {
    const double applied = value_or_throw(cam.set_exposure(t));
    frame = value_or_throw(cam.capture(10.0 + 2.0 * applied));
    const double level = (quantile_of(frame.pixels, quantile) - black) / (full - black);
    double next = t;
    if (level >= 0.97)
      next = t / 8.0;
    else if (level < 1e-3)
      next = t * 16.0;
    else
      next = t * fill / level;
    next = std::clamp(next, range.min_s, range.max_s);
    if (std::abs(next / applied - 1.0) < 0.15 && level < 0.97) break;
    if (next == t && (next == range.min_s || next == range.max_s)) break;  // cannot do better
    t = next;
  }
  if (led_on) value_or_throw(d.light->off());
  if (!exposure_s) s.last_exposure_s[exposure_key] = frame.meta.exposure_s;
  Shot shot;
  shot.name = name;
  shot.raw = to_mono(frame.pixels);
  shot.bit_depth = s.bit_depth;
  shot.exposure_s = frame.meta.exposure_s;
  shot.per_second = true;
  shot.table_angle_deg = angle_deg;
  linearise(s.hdr, &shot);
  const fs::path dir = s.rig.calibration_dir / "captures" / step;
  fs::create_directories(dir);
  shot.file = dir / (name + ".png");
  write_png(shot.file, shot.raw, 16);
  s.captured.push_back(shot.file);
  return shot;
}

std::vector<fs::path> expand_inputs(const std::vector<std::string>& args, const std::string& option) {
  std::vector<fs::path> out;
  auto image_ext = [](const fs::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return e == ".png" || e == ".tif" || e == ".tiff" || e == ".jpg" || e == ".jpeg" || e == ".pgm" || e == ".exr";
  };
  for (const auto& a : args) {
    fs::path p(a);
    if (fs::is_directory(p)) {
      std::vector<fs::path> in;
      for (const auto& e : fs::directory_iterator(p))
        if (e.is_regular_file() && image_ext(e.path())) in.push_back(e.path());
      std::sort(in.begin(), in.end());
      if (in.empty()) throw UsageError(option + " " + a + ": the folder holds no images (.png .tif .jpg .pgm .exr)");
      out.insert(out.end(), in.begin(), in.end());
    } else if (fs::exists(p)) {
      out.push_back(p);
    } else {
      throw UsageError(option + " " + a + ": no such file or folder");
    }
  }
  return out;
}

std::optional<double> angle_from_name(const std::string& name) {
  static const std::regex re(R"(angle[_=]?(-?[0-9]+(?:\.[0-9]+)?))", std::regex::icase);
  std::smatch m;
  if (std::regex_search(name, m, re)) return std::stod(m[1].str());
  return std::nullopt;
}

std::optional<double> exposure_from_name(const std::string& name) {
  static const std::regex re(R"(exp[_=]?([0-9]+(?:\.[0-9]+)?)(ms|us|s)(?![a-z]))", std::regex::icase);
  std::smatch m;
  if (!std::regex_search(name, m, re)) return std::nullopt;
  double v = std::stod(m[1].str());
  std::string unit = m[2].str();
  std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (unit == "ms") v *= 1e-3;
  if (unit == "us") v *= 1e-6;
  return v;
}

Shot load_shot(const fs::path& file, const acq::HdrCalibration& hdr) {
  Shot s;
  s.name = file.stem().string();
  s.file = file;
  s.table_angle_deg = angle_from_name(s.name);
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".exr") {
    ExrImage e = read_exr(file);
    const ImageF* y = e.find("Y");
    if (!y) y = &e.planes.front();
    s.rate = *y;
    s.exposure_s = 1.0;
    s.per_second = true;
    if (const ImageF* valid = e.find("valid")) {
      // Invalid pixels of a merged image are saturated (or below the noise floor): leave
      // them out as clipped.
      s.saturated = Image<std::uint8_t>(valid->width(), valid->height(), 1, 0);
      for (std::size_t i = 0; i < valid->size(); ++i) s.saturated.values()[i] = valid->values()[i] > 0.5f ? 0 : 1;
    }
    return s;
  }
  RawImage raw = read_raw_image(file);
  s.raw = to_mono(raw.pixels);
  s.bit_depth = raw.bit_depth;
  const auto t = exposure_from_name(s.name);
  s.exposure_s = t.value_or(1.0);
  s.per_second = t.has_value();
  linearise(hdr, &s);
  return s;
}

}  // namespace paintlab::app
