#include "paintlab/acquisition/capture.h"
#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <regex>
#include <span>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/result.h"
#include "paintlab/core/robust.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

const char* to_string(Target t) {
  static constexpr EnumNames<Target, 3> kNames{{{Target::Sample, "the sample sphere"},
                                                {Target::WhiteReference, "the white reference sphere"},
                                                {Target::GlossySphere, "the glossy calibration sphere"}}};
  return enum_name(kNames, t);
}

const char* to_string(LensView v) {
  static constexpr EnumNames<LensView, 3> kNames{{{LensView::Scene, "nothing in front of the lens"},
                                                  {LensView::Capped, "the lens cap"},
                                                  {LensView::Diffuser, "the diffuser"}}};
  return enum_name(kNames, v);
}

// ---- Auto exposure ----

double capture_timeout_s(double exposure_s) { return 10.0 + 3.0 * std::max(exposure_s, 0.0); }

double raw_quantile(const Image<std::uint16_t>& img, double q) {
  if (img.size() == 0) throw DataError("raw_quantile: empty image");
  const std::size_t stride = q >= 0.9999 || img.size() < 4096 ? 1 : 4;
  std::vector<std::uint16_t> v;
  v.reserve(img.size() / stride + 1);
  for (std::size_t i = 0; i < img.size(); i += stride) v.push_back(img.values()[i]);
  return lower_quantile_inplace(v, std::clamp(q, 0.0, 1.0));
}

void AutoExposureOptions::check() const {
  auto bad = [](const char* field, double value, const char* rule) {
    throw UsageError(fmt::format("auto exposure: {} = {} ({})", field, value, rule));
  };
  if (!(fill > 0.0 && fill < 0.97)) bad("fill", fill, "a share of the range, 0 < fill < 0.97");
  if (!(quantile >= 0.0 && quantile <= 1.0)) bad("quantile", quantile, "0..1");
  if (!(black_dn >= 0.0) || !std::isfinite(black_dn)) bad("black_dn", black_dn, ">= 0 DN");
  if (!(tolerance > 0.0 && tolerance < 1.0)) bad("tolerance", tolerance, "0 < tolerance < 1");
  if (!(start_s > 0.0) || !std::isfinite(start_s)) bad("start_s", start_s, "> 0 s");
  if (max_frames < 1) bad("max_frames", max_frames, ">= 1");
}

AutoExposure auto_expose(dev::Camera& cam, const AutoExposureOptions& o) {
  o.check();
  const int bits = dev::bit_depth(value_or_throw(cam.pixel_format()));
  const dev::ExposureRange range = value_or_throw(cam.exposure_range());
  const double full = std::ldexp(1.0, bits) - 1.0;
  if (!(o.black_dn < full))
    throw UsageError(
        fmt::format("auto exposure: black_dn = {} is not below the camera's full scale {} DN", o.black_dn, full));
  AutoExposure out;
  double t = std::clamp(o.start_s, range.min_s, range.max_s);
  while (out.frames < o.max_frames) {
    const double applied = value_or_throw(cam.set_exposure(t));
    out.frame = value_or_throw(cam.capture(capture_timeout_s(applied)));
    ++out.frames;
    out.exposure_s = out.frame.meta.exposure_s > 0 ? out.frame.meta.exposure_s : applied;
    out.level = (raw_quantile(out.frame.pixels, o.quantile) - o.black_dn) / (full - o.black_dn);
    const bool measurable = out.level < 0.97 && out.level >= 1e-3;  // neither saturated nor black
    const double wanted = out.level >= 0.97  ? applied / 8.0
                          : out.level < 1e-3 ? applied * 16.0
                                             : applied * o.fill / out.level;
    if (measurable && std::abs(wanted / applied - 1.0) < o.tolerance) {
      out.converged = true;
      return out;
    }
    const double next = std::clamp(wanted, range.min_s, range.max_s);
    // At an end of the camera's range: this frame is as good as it gets.
    if (out.level < 0.97 && next == applied) return out;
    if (next == t && (next == range.min_s || next == range.max_s)) return out;
    t = next;
  }
  spdlog::warn("auto exposure: no exposure within {:.0f} % of the target after {} frames (last {:.4g} s, level {:.3f})",
               100.0 * o.tolerance, out.frames, out.exposure_s, out.level);
  return out;
}

// ---- The LED ----

LightSwitch::LightSwitch(dev::Light& light, bool on) : light_(&light), on_(on) {
  if (on)
    value_or_throw(light.on());
  else
    value_or_throw(light.off());
}

LightSwitch::~LightSwitch() {
  if (!on_) return;
  const Result<void> r = light_->off();
  if (!r) spdlog::error("{}: cannot switch the LED off: {}", light_->id(), r.error().what());
}

void LightSwitch::off() {
  if (!on_) return;
  on_ = false;
  value_or_throw(light_->off());
}

// ---- Exposure stacks ----

std::optional<std::array<int, 4>> cfa_sites(dev::PixelFormat format) {
  const dev::CfaPattern p = dev::cfa_pattern(format);
  if (p == dev::CfaPattern::None) return std::nullopt;
  return std::array<int, 4>{dev::cfa_colour(p, 0, 0), dev::cfa_colour(p, 1, 0), dev::cfa_colour(p, 0, 1),
                            dev::cfa_colour(p, 1, 1)};
}

calib::ExposureStack capture_stack(dev::Camera& cam, dev::Light& light, double gain_db,
                                   const std::vector<double>& exposures_s, int repeats, bool light_on,
                                   const fs::path& save_dir) {
  if (exposures_s.empty()) throw UsageError("capture_stack: no exposure given");
  if (repeats < 1) throw UsageError(fmt::format("capture_stack: repeats = {} (>= 1)", repeats));
  const dev::PixelFormat format = value_or_throw(cam.pixel_format());
  const int bits = dev::bit_depth(format);
  value_or_throw(cam.set_gain_db(gain_db));
  LightSwitch led(light, light_on);
  calib::ExposureStack out;
  out.cfa = cfa_sites(format);
  fs::create_directories(save_dir);
  std::string listing = "# name exposure_s (applied, read back from the camera); pixel format " +
                        std::string(dev::to_string(format)) + "\n";
  int index = 0;
  for (double t : exposures_s)
    for (int r = 0; r < repeats; ++r) {
      const double applied = value_or_throw(cam.set_exposure(t));
      dev::Frame f = value_or_throw(cam.capture(capture_timeout_s(applied)));
      const std::string name = fmt::format("{:03d}.png", index++);
      write_png(save_dir / name, f.pixels, bits <= 8 ? 8 : 16);
      listing += fmt::format("{} {:.9g}\n", name, f.meta.exposure_s);
      out.files.push_back(save_dir / name);
      out.exposures_s.push_back(f.meta.exposure_s);
      out.images.push_back(std::move(f.pixels));
    }
  led.off();
  write_file_atomic(save_dir / "exposures.txt", listing);
  out.bit_depth = bits;
  spdlog::info("captured {} frames into {}", out.images.size(), save_dir.string());
  return out;
}

// ---- Linear frames ----

Linearizer::Linearizer(HdrCalibration calibration) : calibration_(std::move(calibration)) {}

void Linearizer::set_calibration(HdrCalibration calibration) {
  calibration_ = std::move(calibration);
  merger_.reset();
}

Linearizer::Linear Linearizer::linearise(const Image<std::uint16_t>& raw, int bit_depth, double exposure_s) {
  if (!merger_ || width_ != raw.width() || height_ != raw.height() || bit_depth_ != bit_depth) {
    merger_ = std::make_unique<HdrMerger>(calibration_, HdrOptions{}, raw.width(), raw.height(), 1, bit_depth);
    width_ = raw.width();
    height_ = raw.height();
    bit_depth_ = bit_depth;
    ++mergers_built_;
  }
  calib::StackFrame f{&raw, exposure_s};
  HdrResult r = merger_->merge(std::span<const calib::StackFrame>(&f, 1));
  Linear out;
  out.rate = r.image.plane(r.image.names.front());
  const double full = std::ldexp(1.0, bit_depth) - 1.0;
  const double sat = std::min(merger_->window().saturation_dn, 0.995 * full);
  out.saturated = Image<std::uint8_t>(raw.width(), raw.height(), 1, 0);
  for (std::size_t i = 0; i < raw.size(); ++i) out.saturated.values()[i] = raw.values()[i] >= sat ? 1 : 0;
  return out;
}

// ---- Shots ----

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
  std::transform(unit.begin(), unit.end(), unit.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (unit == "ms") v *= 1e-3;
  if (unit == "us") v *= 1e-6;
  return v;
}

Shot load_shot(const fs::path& file, Linearizer& linearizer) {
  Shot s;
  s.name = file.stem().string();
  s.file = file;
  s.table_angle_deg = angle_from_name(s.name);
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
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
  Linearizer::Linear lin = linearizer.linearise(s.raw, s.bit_depth, s.exposure_s);
  s.rate = std::move(lin.rate);
  s.saturated = std::move(lin.saturated);
  return s;
}

ShotCapture::ShotCapture(Devices devices, fs::path captures_dir, double settle_s, double tolerance)
    : d_(devices), dir_(std::move(captures_dir)), settle_s_(settle_s), tolerance_(tolerance) {
  if (!d_.light || !d_.camera || !d_.clock)
    throw UsageError("ShotCapture: the light, the camera and a clock are needed");
}

Shot ShotCapture::capture(const ShotRequest& q, Linearizer& linearizer) {
  if (q.angle_deg) {
    if (!d_.table)
      throw UsageError(
          fmt::format("shot {}/{}: a table angle was asked for, but the rig has no turntable open", q.step, q.name));
    value_or_throw(d_.table->move_to(wrap_360(*q.angle_deg)));
    value_or_throw(d_.table->wait_settled(120.0));
    if (settle_s_ > 0) d_.clock->sleep_s(settle_s_);
  }
  dev::Camera& cam = *d_.camera;
  if (bit_depth_ == 0) bit_depth_ = dev::bit_depth(value_or_throw(cam.pixel_format()));
  const HdrCalibration& hdr = linearizer.calibration();
  // One frame at the asked exposure, or auto-exposed from where this step's last one ended.
  auto take = [&](const std::string& filter) {
    if (q.exposure_s) {
      value_or_throw(cam.set_exposure(*q.exposure_s));
      return value_or_throw(cam.capture(capture_timeout_s(*q.exposure_s)));
    }
    const std::string key = fmt::format("{}/{}{}", q.step, q.led_on ? "on" : "off", filter);
    AutoExposureOptions ae;
    ae.fill = q.fill;
    ae.quantile = q.quantile;
    ae.black_dn = hdr.dark ? hdr.dark->mean_bias_dn : 0.0;
    ae.tolerance = tolerance_;
    const auto previous = last_exposure_s_.find(key);
    if (previous != last_exposure_s_.end()) ae.start_s = previous->second;
    AutoExposure found = auto_expose(cam, ae);
    last_exposure_s_[key] = found.frame.meta.exposure_s;
    return std::move(found.frame);
  };
  if (d_.wheel) return capture_through_wheel(q, linearizer, take);
  dev::Frame frame;
  {
    LightSwitch led(*d_.light, q.led_on);
    frame = take("");
    led.off();
  }
  Shot shot;
  shot.name = q.name;
  shot.cfa = dev::cfa_pattern(frame.meta.format);
  shot.raw = shot.cfa == dev::CfaPattern::None ? to_mono(frame.pixels) : std::move(frame.pixels);
  shot.bit_depth = bit_depth_;
  shot.exposure_s = frame.meta.exposure_s;
  shot.per_second = true;
  shot.table_angle_deg = q.angle_deg;
  Linearizer::Linear lin = linearizer.linearise(shot.raw, shot.bit_depth, shot.exposure_s);
  if (shot.cfa == dev::CfaPattern::None) {
    shot.rate = std::move(lin.rate);
    shot.saturated = std::move(lin.saturated);
  } else {  // a mosaic: the geometric steps see its (grey-balanced) luminance; a clipped site spoils its 3x3 neighbours
    shot.rgb = demosaic_bilinear(lin.rate, shot.cfa);
    // The camera's colour gains from this shot when it shows enough grey (boards, references),
    // else the last ones measured (a highlight on a dark glossy sphere shows too little).
    if (const auto g = grey_gains(lin.rate, shot.cfa)) cfa_gains_ = *g;
    if (!cfa_gains_)
      spdlog::warn("{}/{}: the colour gains are not known yet (too little grey in view): its luminance keeps the "
                   "filters' 2x2 pattern",
                   q.step, q.name);
    shot.rate = balanced_luminance(lin.rate, shot.cfa, cfa_gains_.value_or(std::array<double, 3>{1.0, 1.0, 1.0}));
    shot.blur_var_px2 = 0.5;  // [1 2 1] / 4 along each axis
    shot.saturated = Image<std::uint8_t>(lin.saturated.width(), lin.saturated.height(), 1, 0);
    for (int y = 0; y < lin.saturated.height(); ++y)
      for (int x = 0; x < lin.saturated.width(); ++x)
        if (lin.saturated.at(x, y))
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int sx = x + dx, sy = y + dy;
              if (sx >= 0 && sy >= 0 && sx < lin.saturated.width() && sy < lin.saturated.height())
                shot.saturated.at(sx, sy) = 1;
            }
  }
  const fs::path dir = dir_ / q.step;
  fs::create_directories(dir);
  shot.file = dir / (q.name + ".png");
  write_png(shot.file, shot.raw, 16);
  captured_.push_back(shot.file);
  return shot;
}

Shot ShotCapture::capture_through_wheel(const ShotRequest& q, Linearizer& linearizer,
                                        const std::function<dev::Frame(const std::string&)>& take) {
  std::array<dev::Frame, 3> frames;
  {
    LightSwitch led(*d_.light, q.led_on);
    for (int c = 0; c < 3; ++c) {
      const int slot = d_.wheel_slots[static_cast<std::size_t>(c)];
      value_or_throw(d_.wheel->move_to(slot));
      const int at = value_or_throw(d_.wheel->position());
      if (at != slot)
        throw DeviceError(d_.wheel->id(),
                          fmt::format("at slot {} after the move to slot {} ({} filter)", at, slot, "RGB"[c]), false);
      frames[static_cast<std::size_t>(c)] = take(std::string("/") + "RGB"[c]);
    }
    led.off();
  }
  Shot shot;
  shot.name = q.name;
  shot.bit_depth = bit_depth_;
  shot.per_second = true;
  shot.table_angle_deg = q.angle_deg;
  const fs::path dir = dir_ / q.step;
  fs::create_directories(dir);
  std::array<ImageF, 3> rate;
  for (int c = 0; c < 3; ++c) {
    dev::Frame& f = frames[static_cast<std::size_t>(c)];
    Linearizer::Linear lin = linearizer.linearise(f.pixels, shot.bit_depth, f.meta.exposure_s);
    rate[static_cast<std::size_t>(c)] = std::move(lin.rate);
    if (shot.saturated.empty()) shot.saturated = Image<std::uint8_t>(lin.saturated.width(), lin.saturated.height(), 1, 0);
    for (std::size_t i = 0; i < shot.saturated.size(); ++i) shot.saturated.values()[i] |= lin.saturated.values()[i];
    const fs::path file = dir / fmt::format("{}_{}.png", q.name, "RGB"[c]);
    write_png(file, f.pixels, 16);
    captured_.push_back(file);
    if (c == 1) {  // the green frame stands for the shot (its file, its exposure)
      shot.file = file;
      shot.exposure_s = f.meta.exposure_s;
      shot.raw = std::move(f.pixels);
    }
  }
  const int w = rate[0].width(), h = rate[0].height();
  shot.rgb = ImageF(w, h, 3);
  shot.rate = ImageF(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) shot.rgb.at(x, y, c) = rate[static_cast<std::size_t>(c)].at(x, y);
      shot.rate.at(x, y) = 0.25f * (rate[0].at(x, y) + 2.0f * rate[1].at(x, y) + rate[2].at(x, y));
    }
  return shot;
}

}  // namespace paintlab::acq
