#include "paintlab/devices/aravis_camera.h"

#include <arv.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/core/log.h"

namespace paintlab::dev {

struct AravisCamera::Impl {
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;
  gulong lost_handler = 0;
  std::atomic<bool> lost{false};
  bool has_float_gain = false;
  std::string vendor, model, serial;

  ~Impl() {
    if (stream) g_object_unref(stream);
    if (camera) {
      if (lost_handler) g_signal_handler_disconnect(arv_camera_get_device(camera), lost_handler);
      g_object_unref(camera);
    }
  }
};

namespace {

ArvPixelFormat to_arv(PixelFormat f) { return static_cast<ArvPixelFormat>(pfnc_code(f)); }

std::optional<PixelFormat> from_arv(ArvPixelFormat f) { return pixel_format_from_pfnc(static_cast<std::uint32_t>(f)); }

const char* status_name(ArvBufferStatus s) {
  switch (s) {
    case ARV_BUFFER_STATUS_SUCCESS: return "success";
    case ARV_BUFFER_STATUS_CLEARED: return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT: return "timeout (incomplete frame)";
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "size mismatch";
    case ARV_BUFFER_STATUS_FILLING: return "still filling";
    case ARV_BUFFER_STATUS_ABORTED: return "aborted";
    default: return "unknown status";
  }
}

// Takes ownership of a GError and returns its message ("" when none).
std::string take_error(GError*& e) {
  if (!e) return {};
  std::string m = e->message ? e->message : "unknown Aravis error";
  g_clear_error(&e);
  return m;
}

void on_control_lost(ArvDevice*, gpointer data) { static_cast<std::atomic<bool>*>(data)->store(true); }

// Like take_error, and a control command that failed after Aravis' own retries (timeout,
// not connected, transfer error) marks the camera gone: every later command would wait
// for the same timeouts.
std::string take_control_error(GError*& e, std::atomic<bool>& lost) {
  if (e && e->domain == ARV_DEVICE_ERROR &&
      (e->code == ARV_DEVICE_ERROR_TIMEOUT || e->code == ARV_DEVICE_ERROR_NOT_CONNECTED ||
       e->code == ARV_DEVICE_ERROR_TRANSFER_ERROR))
    lost.store(true);
  return take_error(e);
}

}  // namespace

void AravisCameraConfig::check() const {
  auto bad = [](const std::string& m) { throw DataError("aravis camera config: " + m); };
  if (id.empty()) bad("id (device id or IP address) is required");
  if (width_px < 0 || height_px < 0) bad("width_px and height_px must be >= 0");
  if (packet_size != 0 && (packet_size < 576 || packet_size > 16384)) bad("packet_size must be 0 or in [576, 16384]");
  if (n_buffers < 1) bad("n_buffers must be >= 1");
  if (!(frame_timeout_s > 0)) bad("frame_timeout_ms must be > 0");
  if (max_retries < 0) bad("max_retries must be >= 0");
  if (settle_frames < 0) bad("settle_frames must be >= 0");
  if (readout_s < 0) bad("readout_ms must be >= 0");
}

AravisCameraConfig aravis_camera_config(const ConfigTable& t, bool simulated) {
  AravisCameraConfig c;
  if (simulated) {
    if (t.has("id")) t.fail("id", "the simulated camera is always at 127.0.0.1; remove this key");
    c.id = "127.0.0.1";
  } else {
    c.id = t.string("id");
    if (c.id.empty()) t.fail("id", "must name the camera (device id or IP address)");
  }
  // RGB8 (three values a pixel) is read by the driver but not served by the simulator nor
  // merged by the measurement: not offered here.
  c.pixel_format = pixel_format_from_string(
      t.choice("pixel_format", "Mono16",
               {"Mono8", "Mono12", "Mono16", "BayerRG8", "BayerGR8", "BayerGB8", "BayerBG8", "BayerRG12", "BayerGR12",
                "BayerGB12", "BayerBG12", "BayerRG16", "BayerGR16", "BayerGB16", "BayerBG16"}));
  c.width_px = static_cast<int>(t.integer("width_px", 0, Bounds::closed(0, 65535)));
  c.height_px = static_cast<int>(t.integer("height_px", 0, Bounds::closed(0, 65535)));
  if (t.has("black_level")) c.black_level = t.number("black_level", Bounds::closed(-1e6, 1e6));
  c.packet_size = static_cast<int>(t.integer("packet_size", 0, Bounds::closed(0, 16384)));
  if (c.packet_size != 0 && c.packet_size < 576) t.fail("packet_size", "must be 0 (negotiate) or in [576, 16384]");
  c.packet_resend = t.boolean("packet_resend", c.packet_resend);
  c.packet_timeout_s = t.number("packet_timeout_ms", c.packet_timeout_s * 1e3, Bounds::closed(0.01, 10000)) * 1e-3;
  c.frame_retention_s = t.number("frame_retention_ms", c.frame_retention_s * 1e3, Bounds::closed(0.01, 60000)) * 1e-3;
  c.initial_packet_timeout_s =
      t.number("initial_packet_timeout_ms", c.initial_packet_timeout_s * 1e3, Bounds::closed(0.0, 10000)) * 1e-3;
  c.n_buffers = static_cast<int>(t.integer("n_buffers", c.n_buffers, Bounds::closed(1, 64)));
  c.frame_timeout_s = t.number("frame_timeout_ms", c.frame_timeout_s * 1e3, Bounds::closed(1, 600000)) * 1e-3;
  c.max_retries = static_cast<int>(t.integer("max_retries", c.max_retries, Bounds::closed(0, 100)));
  c.settle_frames = static_cast<int>(t.integer("settle_frames", c.settle_frames, Bounds::closed(0, 100)));
  c.readout_s = t.number("readout_ms", c.readout_s * 1e3, Bounds::closed(0, 10000)) * 1e-3;
  c.gain_db_per_raw = t.number("gain_db_per_raw", c.gain_db_per_raw, Bounds::closed(0, 100));
  t.accept("kind");
  t.finish();
  return c;
}

AravisCamera::AravisCamera(AravisCameraConfig config, std::unique_ptr<Impl> impl)
    : config_(std::move(config)), impl_(std::move(impl)) {}

AravisCamera::~AravisCamera() {
  std::lock_guard lock(mutex_);
  stop_stream_locked();
}

Result<std::unique_ptr<AravisCamera>> AravisCamera::open(AravisCameraConfig config) {
  config.check();
  std::string name = "camera aravis " + config.id;
  auto impl = std::make_unique<Impl>();
  GError* err = nullptr;
  impl->camera = arv_camera_new(config.id.c_str(), &err);
  if (!impl->camera) return device_failure(name, "cannot open the camera: " + take_error(err), true);
  ArvDevice* device = arv_camera_get_device(impl->camera);
  impl->lost_handler = g_signal_connect(device, "control-lost", G_CALLBACK(on_control_lost), &impl->lost);
  auto fail = [&](const std::string& what) {
    return device_failure(name, what + ": " + take_error(err), false);
  };
  const char* s = arv_camera_get_vendor_name(impl->camera, &err);
  impl->vendor = s ? s : "";
  g_clear_error(&err);
  s = arv_camera_get_model_name(impl->camera, &err);
  impl->model = s ? s : "";
  g_clear_error(&err);
  s = arv_camera_get_device_serial_number(impl->camera, &err);
  impl->serial = s ? s : "";
  g_clear_error(&err);

  if (arv_camera_is_gv_device(impl->camera)) {
    if (config.packet_size > 0)
      arv_camera_gv_set_packet_size(impl->camera, config.packet_size, &err);
    else
      arv_camera_gv_auto_packet_size(impl->camera, &err);
    if (err) return fail("cannot set the GigE Vision packet size");
  }
  if (config.width_px > 0 && config.height_px > 0) {
    arv_camera_set_region(impl->camera, 0, 0, config.width_px, config.height_px, &err);
    if (err) return fail(fmt::format("cannot set the region {}x{}", config.width_px, config.height_px));
  }
  arv_camera_set_pixel_format(impl->camera, to_arv(config.pixel_format), &err);
  if (err) return fail(std::string("cannot set PixelFormat ") + to_string(config.pixel_format));
  if (config.black_level) {
    arv_camera_set_black_level(impl->camera, *config.black_level, &err);
    if (err) return fail("cannot set the black level");
  }
  arv_camera_set_acquisition_mode(impl->camera, ARV_ACQUISITION_MODE_CONTINUOUS, &err);
  if (err) return fail("cannot set AcquisitionMode Continuous");
  arv_camera_set_trigger(impl->camera, "Software", &err);
  if (err) return fail("cannot set the software trigger (TriggerMode On, TriggerSource Software)");
  impl->has_float_gain = arv_camera_is_feature_available(impl->camera, "Gain", &err) != FALSE;
  g_clear_error(&err);

  std::unique_ptr<AravisCamera> cam(new AravisCamera(config, std::move(impl)));
  cam->format_ = config.pixel_format;
  auto fmt_back = cam->read_format_locked();
  if (!fmt_back) return tl::unexpected(fmt_back.error());
  if (*fmt_back != config.pixel_format)
    return device_failure(name, fmt::format("PixelFormat {} requested, camera reports {}", to_string(config.pixel_format),
                                            to_string(*fmt_back)),
                          false);
  double exposure_us = arv_camera_get_exposure_time(cam->impl_->camera, &err);
  if (err) return fail("cannot read the exposure time");
  cam->exposure_s_ = exposure_us * 1e-6;
  if (arv_camera_is_gain_available(cam->impl_->camera, nullptr)) {
    double g = arv_camera_get_gain(cam->impl_->camera, &err);
    g_clear_error(&err);
    cam->gain_db_ = cam->impl_->has_float_gain ? g : g * config.gain_db_per_raw;
  }
  std::lock_guard lock(cam->mutex_);
  if (auto r = cam->start_stream_locked(); !r) return tl::unexpected(r.error());
  return cam;
}

std::string AravisCamera::id() const { return "camera aravis " + config_.id; }
std::string AravisCamera::serial() const { return impl_->serial; }
std::string AravisCamera::model() const { return impl_->vendor + " " + impl_->model; }
bool AravisCamera::control_lost() const { return impl_->lost.load(); }

Result<void> AravisCamera::lost_check() const {
  if (impl_->lost.load()) return device_failure(id(), "the camera is gone (GigE Vision control channel lost)", false);
  return {};
}

Result<void> AravisCamera::start_stream_locked() {
  GError* err = nullptr;
  impl_->stream = arv_camera_create_stream(impl_->camera, nullptr, nullptr, &err);
  if (!impl_->stream) return device_failure(id(), "cannot create the stream: " + take_error(err), true);
  if (ARV_IS_GV_STREAM(impl_->stream)) {
    g_object_set(impl_->stream, "packet-resend",
                 config_.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                 "packet-timeout", static_cast<guint>(std::lround(config_.packet_timeout_s * 1e6)), "frame-retention",
                 static_cast<guint>(std::lround(config_.frame_retention_s * 1e6)), "initial-packet-timeout",
                 static_cast<guint>(std::lround(config_.initial_packet_timeout_s * 1e6)), nullptr);
  }
  guint payload = arv_camera_get_payload(impl_->camera, &err);
  if (err || payload == 0) return device_failure(id(), "cannot read PayloadSize: " + take_error(err), false);
  for (int i = 0; i < config_.n_buffers; ++i) arv_stream_push_buffer(impl_->stream, arv_buffer_new(payload, nullptr));
  arv_camera_start_acquisition(impl_->camera, &err);
  if (err) return device_failure(id(), "cannot start the acquisition: " + take_error(err), true);
  return {};
}

void AravisCamera::stop_stream_locked() {
  if (!impl_->stream) return;
  GError* err = nullptr;
  if (!impl_->lost.load()) arv_camera_stop_acquisition(impl_->camera, &err);
  g_clear_error(&err);
  g_object_unref(impl_->stream);
  impl_->stream = nullptr;
}

Result<ExposureRange> AravisCamera::exposure_range() {
  std::lock_guard lock(mutex_);
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  GError* err = nullptr;
  double lo = 0, hi = 0;
  arv_camera_get_exposure_time_bounds(impl_->camera, &lo, &hi, &err);
  if (err) return device_failure(id(), "cannot read the exposure bounds: " + take_control_error(err, impl_->lost), true);
  return ExposureRange{lo * 1e-6, hi * 1e-6};
}

Result<double> AravisCamera::set_exposure(double seconds) {
  std::lock_guard lock(mutex_);
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  GError* err = nullptr;
  double lo = 0, hi = 0;
  arv_camera_get_exposure_time_bounds(impl_->camera, &lo, &hi, &err);
  if (err) return device_failure(id(), "cannot read the exposure bounds: " + take_control_error(err, impl_->lost), true);
  double us = seconds * 1e6;
  if (!std::isfinite(us) || us < lo || us > hi)
    return device_failure(id(), fmt::format("exposure {:g} s is outside the camera's range [{:g}, {:g}] s", seconds,
                                            lo * 1e-6, hi * 1e-6),
                          false);
  arv_camera_set_exposure_time(impl_->camera, us, &err);
  if (err) return device_failure(id(), "cannot set the exposure time: " + take_control_error(err, impl_->lost), true);
  double back = arv_camera_get_exposure_time(impl_->camera, &err);
  if (err) return device_failure(id(), "cannot read the exposure time back: " + take_control_error(err, impl_->lost), true);
  double applied = back * 1e-6;
  if (applied != exposure_s_) pending_settle_ = config_.settle_frames;
  exposure_s_ = applied;
  return applied;
}

Result<double> AravisCamera::set_gain_db(double gain_db) {
  std::lock_guard lock(mutex_);
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  GError* err = nullptr;
  if (!arv_camera_is_gain_available(impl_->camera, &err)) {
    g_clear_error(&err);
    if (gain_db == 0.0) return 0.0;
    return device_failure(id(), "the camera has no gain feature", false);
  }
  double value = gain_db;
  if (!impl_->has_float_gain) {
    if (config_.gain_db_per_raw <= 0) {
      if (gain_db == 0.0) value = 0.0;
      else
        return device_failure(id(), "the camera offers only GainRaw; set gain_db_per_raw in rig.toml to use dB", false);
    } else {
      value = std::round(gain_db / config_.gain_db_per_raw);
    }
  }
  double lo = 0, hi = 0;
  arv_camera_get_gain_bounds(impl_->camera, &lo, &hi, &err);
  if (err) return device_failure(id(), "cannot read the gain bounds: " + take_control_error(err, impl_->lost), true);
  if (!std::isfinite(value) || value < lo || value > hi)
    return device_failure(id(), fmt::format("gain {:g} dB is outside the camera's range", gain_db), false);
  arv_camera_set_gain(impl_->camera, value, &err);
  if (err) return device_failure(id(), "cannot set the gain: " + take_control_error(err, impl_->lost), true);
  double back = arv_camera_get_gain(impl_->camera, &err);
  if (err) return device_failure(id(), "cannot read the gain back: " + take_control_error(err, impl_->lost), true);
  double applied = impl_->has_float_gain ? back : back * config_.gain_db_per_raw;
  if (applied != gain_db_) pending_settle_ = config_.settle_frames;
  gain_db_ = applied;
  return applied;
}

Result<PixelFormat> AravisCamera::pixel_format() {
  std::lock_guard lock(mutex_);
  return read_format_locked();
}

Result<PixelFormat> AravisCamera::read_format_locked() {
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  GError* err = nullptr;
  ArvPixelFormat f = arv_camera_get_pixel_format(impl_->camera, &err);
  if (err) return device_failure(id(), "cannot read PixelFormat: " + take_control_error(err, impl_->lost), true);
  auto p = from_arv(f);
  if (!p) return device_failure(id(), fmt::format("unsupported PixelFormat 0x{:08X}", static_cast<unsigned>(f)), false);
  return *p;
}

Result<void> AravisCamera::set_pixel_format(PixelFormat format) {
  std::lock_guard lock(mutex_);
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  if (format == format_) return {};
  // PixelFormat is locked during acquisition on most cameras; the payload changes too.
  stop_stream_locked();
  GError* err = nullptr;
  arv_camera_set_pixel_format(impl_->camera, to_arv(format), &err);
  if (err) {
    std::string m = take_control_error(err, impl_->lost);
    start_stream_locked();
    return device_failure(id(), std::string("cannot set PixelFormat ") + to_string(format) + ": " + m, false);
  }
  auto back = read_format_locked();
  if (!back) return tl::unexpected(back.error());
  if (*back != format)
    return device_failure(id(), fmt::format("PixelFormat {} requested, camera reports {}", to_string(format),
                                            to_string(*back)),
                          false);
  format_ = format;
  pending_settle_ = config_.settle_frames;
  return start_stream_locked();
}

Result<Frame> AravisCamera::capture(double timeout_s) {
  std::lock_guard lock(mutex_);
  if (auto r = lost_check(); !r) return tl::unexpected(r.error());
  if (!impl_->stream) return device_failure(id(), "no stream (acquisition not running)", true);
  using Clock = std::chrono::steady_clock;
  auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  // One attempt waits for the exposure, the readout and the transfer allowance.
  double attempt_wait_s = exposure_s_ + config_.readout_s + config_.frame_timeout_s;
  int failures = 0;
  std::string last;
  // Unpacked GenICam formats: one byte a value up to 8 bits, else a little-endian 16-bit word;
  // RGB8 holds three values a pixel.
  const std::size_t bytes_per_value = bit_depth(format_) > 8 ? 2 : 1;
  const std::size_t bytes_per_px = bytes_per_value * static_cast<std::size_t>(channels(format_));
  while (failures <= config_.max_retries) {
    // Frames that arrived without our trigger are stale: give their buffers back.
    while (ArvBuffer* stale = arv_stream_try_pop_buffer(impl_->stream)) arv_stream_push_buffer(impl_->stream, stale);
    double remaining = std::chrono::duration<double>(deadline - Clock::now()).count();
    if (remaining <= 0) break;
    GError* err = nullptr;
    arv_camera_software_trigger(impl_->camera, &err);
    if (err) {
      last = "software trigger failed: " + take_control_error(err, impl_->lost);
      ++failures;
      if (impl_->lost.load()) break;
      continue;
    }
    double wait = std::min(attempt_wait_s, remaining);
    ArvBuffer* buf = arv_stream_timeout_pop_buffer(impl_->stream, static_cast<guint64>(wait * 1e6));
    if (!buf) {
      last = fmt::format("no frame within {:.3g} s of the trigger", wait);
      ++failures;
      ++bad_buffers_;
      continue;
    }
    ArvBufferStatus st = arv_buffer_get_status(buf);
    bool good = st == ARV_BUFFER_STATUS_SUCCESS;
    std::string why = status_name(st);
    int w = 0, h = 0;
    std::size_t size = 0;
    const void* data = nullptr;
    if (good) {
      if (arv_buffer_get_payload_type(buf) != ARV_BUFFER_PAYLOAD_TYPE_IMAGE) {
        good = false;
        why = "not an image payload";
      } else if (from_arv(arv_buffer_get_image_pixel_format(buf)) != format_) {
        good = false;
        why = "pixel format differs from the one set";
      } else {
        w = arv_buffer_get_image_width(buf);
        h = arv_buffer_get_image_height(buf);
        data = arv_buffer_get_image_data(buf, &size);
        if (!data || w <= 0 || h <= 0 || size < static_cast<std::size_t>(w) * h * bytes_per_px) {
          good = false;
          why = fmt::format("image data too short ({} bytes for {}x{})", size, w, h);
        }
      }
    }
    if (!good) {
      arv_stream_push_buffer(impl_->stream, buf);
      ++bad_buffers_;
      ++failures;
      last = "bad buffer: " + why;
      spdlog::debug("{}: {} (attempt {})", id(), last, failures);
      continue;
    }
    if (pending_settle_ > 0) {
      --pending_settle_;
      arv_stream_push_buffer(impl_->stream, buf);
      continue;
    }
    Frame f;
    f.pixels = Image<std::uint16_t>(w, h, channels(format_));
    const auto* p = static_cast<const std::uint8_t*>(data);
    std::uint16_t* out = f.pixels.data();
    const std::size_t n = f.pixels.size();
    if (bytes_per_value == 1) {
      std::copy(p, p + n, out);
    } else {
      for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<std::uint16_t>(p[2 * i] | (p[2 * i + 1] << 8));
    }
    f.meta.exposure_s = exposure_s_;
    f.meta.gain_db = gain_db_;
    f.meta.frame_id = arv_buffer_get_frame_id(buf);
    f.meta.timestamp_ns = arv_buffer_get_timestamp(buf);
    f.meta.format = format_;
    arv_stream_push_buffer(impl_->stream, buf);
    if (failures > 0) ++retried_captures_;
    return f;
  }
  if (impl_->lost.load()) return device_failure(id(), "the camera is gone (GigE Vision control channel lost): " + last, false);
  return device_failure(id(),
                        fmt::format("no good frame after {} attempts within {:g} s: {}", failures, timeout_s,
                                    last.empty() ? "timeout" : last),
                        true);
}

Result<CameraProbe> probe_aravis_camera(const std::string& id_or_address) {
  GError* err = nullptr;
  ArvCamera* cam = arv_camera_new(id_or_address.c_str(), &err);
  if (!cam) return device_failure("camera aravis " + id_or_address, "no camera answers: " + take_error(err), true);
  CameraProbe p;
  auto str = [&](const char* s) {
    std::string v = s ? s : "";
    g_clear_error(&err);
    return v;
  };
  p.vendor = str(arv_camera_get_vendor_name(cam, &err));
  p.model = str(arv_camera_get_model_name(cam, &err));
  p.serial = str(arv_camera_get_device_serial_number(cam, &err));
  p.device_id = str(arv_camera_get_device_id(cam, &err));
  p.address = id_or_address;
  g_object_unref(cam);
  return p;
}

std::vector<CameraProbe> discover_aravis_cameras() {
  arv_update_device_list();
  std::vector<CameraProbe> out;
  for (unsigned i = 0, n = arv_get_n_devices(); i < n; ++i) {
    auto str = [](const char* s) { return std::string(s ? s : ""); };
    CameraProbe p;
    p.device_id = str(arv_get_device_id(i));
    p.vendor = str(arv_get_device_vendor(i));
    p.model = str(arv_get_device_model(i));
    p.serial = str(arv_get_device_serial_nbr(i));
    p.address = str(arv_get_device_address(i));
    out.push_back(p);
  }
  return out;
}

}  // namespace paintlab::dev
