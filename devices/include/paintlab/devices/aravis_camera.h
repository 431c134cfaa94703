#pragma once
// AravisCamera: a GenICam camera (GigE Vision or USB3 Vision) through Aravis 0.8. Opened by
// device id or IP address (never by broadcast discovery). Features go through Aravis'
// helpers, which pick the modern SFNC names (ExposureTime in us, Gain in dB, BlackLevel) or
// the older ones (ExposureTimeAbs, GainRaw, BlackLevelRaw) the camera offers. Frames are
// taken with a software trigger; a buffer that is not complete (timeout, missing packets,
// size mismatch, ...) is never returned: the capture is retried a bounded number of times
// and then fails with a retryable DeviceError.
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/core/config.h"
#include "paintlab/devices/camera.h"

namespace paintlab::dev {

struct AravisCameraConfig {
  std::string id;  // Aravis device id or IP address ("127.0.0.1", "Basler-21234567")
  PixelFormat pixel_format = PixelFormat::Mono16;
  int width_px = 0;   // 0: keep the camera's region
  int height_px = 0;
  std::optional<double> black_level;  // applied at open when given (camera units)
  // GigE Vision stream: packet size (0 = negotiate with the camera), resend requests and
  // the stream's timeouts.
  int packet_size = 0;
  bool packet_resend = true;
  double packet_timeout_s = 0.020;
  double frame_retention_s = 0.100;
  double initial_packet_timeout_s = 0.001;
  int n_buffers = 4;
  double frame_timeout_s = 2.0;   // one capture attempt waits at most this long for its frame
  int max_retries = 2;            // extra capture attempts after a bad or missing buffer
  int settle_frames = 0;          // frames discarded after each exposure or gain change
  double readout_s = 0.0;         // sensor readout per frame (rig data sheet)
  // Cameras with only GainRaw: dB per raw unit (0 = unknown: only gain 0 is accepted).
  double gain_db_per_raw = 0.0;

  void check() const;  // throws DataError naming the first violated rule
};

// Reads a [devices.camera] table of kind "aravis" (or, with `simulated`, of kind "sim":
// no `id`, the camera is the GigE Vision fake on 127.0.0.1); unknown keys are ConfigErrors.
AravisCameraConfig aravis_camera_config(const ConfigTable& table, bool simulated = false);

class AravisCamera final : public Camera {
 public:
  // Connects (by id or address), sets pixel format, region, black level, trigger (software,
  // FrameStart), acquisition mode Continuous and the stream, and starts acquisition.
  // A camera that cannot be reached is a retryable failure.
  static Result<std::unique_ptr<AravisCamera>> open(AravisCameraConfig config);
  ~AravisCamera() override;
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  std::string id() const override;
  std::string serial() const override;
  Result<ExposureRange> exposure_range() override;
  Result<double> set_exposure(double seconds) override;
  Result<double> set_gain_db(double gain_db) override;
  Result<void> set_pixel_format(PixelFormat format) override;
  Result<PixelFormat> pixel_format() override;
  double readout_s() const override { return config_.readout_s; }
  Result<Frame> capture(double timeout_s) override;

  // Camera vendor and model as the device reports them.
  std::string model() const;
  // Bad buffers seen (and dropped) and captures that needed a retry, since open.
  int bad_buffers() const { return bad_buffers_; }
  int retried_captures() const { return retried_captures_; }
  // Whether Aravis reported the control channel lost (the camera disappeared).
  bool control_lost() const;

 private:
  struct Impl;
  AravisCamera(AravisCameraConfig config, std::unique_ptr<Impl> impl);
  Result<void> start_stream_locked();
  void stop_stream_locked();
  Result<void> lost_check() const;
  Result<PixelFormat> read_format_locked();

  AravisCameraConfig config_;
  std::unique_ptr<Impl> impl_;
  std::mutex mutex_;
  double exposure_s_ = 0.0;  // read back after each set
  double gain_db_ = 0.0;
  PixelFormat format_ = PixelFormat::Mono16;
  int pending_settle_ = 0;
  int bad_buffers_ = 0;
  int retried_captures_ = 0;
};

// Identity of the camera at an address or id, without starting acquisition (for
// `paintlab devices`). Fails (retryable) when nothing answers.
struct CameraProbe {
  std::string vendor, model, serial, device_id, address;
};
Result<CameraProbe> probe_aravis_camera(const std::string& id_or_address);
// Aravis' discovery: broadcasts on every network interface and scans USB. Only on explicit
// request (`paintlab devices --discover`), never in tests.
std::vector<CameraProbe> discover_aravis_cameras();

}  // namespace paintlab::dev
