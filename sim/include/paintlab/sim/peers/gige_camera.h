#pragma once
// The simulated camera: Aravis' GigE Vision fake camera on 127.0.0.1 (real GVCP/GVSP on
// port 3956), run in-process with our own GenICam XML that uses the modern feature names
// (ExposureTime in us, Gain in dB, BlackLevel; PixelFormat Mono8/Mono12/Mono16), and a fill
// callback that takes each frame from a FrameSource for the exposure and gain the camera is
// set to. Filling a frame advances the sim clock by exposure + readout. Only one fake can
// hold port 3956 at a time (tests use ctest RESOURCE_LOCK "gige").
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "paintlab/core/clock.h"
#include "paintlab/devices/camera.h"

namespace paintlab::sim {

// What the camera is asked for when it fills one frame.
struct FrameRequest {
  double exposure_s = 0.0;  // applied (register value, 1 us steps)
  double gain_db = 0.0;     // applied (0.1 dB steps)
  double black_level = 0.0; // DN added to every pixel
  dev::PixelFormat format = dev::PixelFormat::Mono16;
  int width = 0;
  int height = 0;
  std::uint64_t index = 0;  // frames filled before this one
};

// Fills width*height pixels (row-major) with raw values of bit_depth(format) bits.
using FrameSource = std::function<void(const FrameRequest&, std::uint16_t* pixels)>;

// A deterministic pattern a test can predict: a signal rate that ramps from 25 % to 100 %
// of kAnalyticRate (DN/s at 0 dB) along x + y, times exposure and the gain as an amplitude
// factor 10^(dB/20), plus the black level, rounded and clipped to the format's range.
inline constexpr double kAnalyticRateDnPerS = 1.0e5;
std::uint16_t analytic_pixel(const FrameRequest& r, int x, int y);
void analytic_frame(const FrameRequest& r, std::uint16_t* pixels);

struct GigeCameraOptions {
  int width = 640;
  int height = 480;
  std::string serial = "PAINTLAB-SIM-1";
  double readout_s = 0.010;  // sensor readout time per frame
  dev::PixelFormat format = dev::PixelFormat::Mono16;
  double black_level = 0.0;  // initial BlackLevel (DN)
};

// Faults, switched on per test.
// Machine-wide ownership of the GigE Vision control port 127.0.0.1:3956. Two fake cameras
// would both bind it and answer each other's clients, so every simulated camera (and a test
// that starts Aravis' own fake program) holds this lock while it serves: a second one waits
// until the first stops (a lock file under /tmp; also waits while a program that takes no
// lock holds the port). Throws DeviceError after `timeout_s`.
class GigePortLock {
 public:
  explicit GigePortLock(double timeout_s = 1200.0);
  ~GigePortLock();
  GigePortLock(const GigePortLock&) = delete;
  GigePortLock& operator=(const GigePortLock&) = delete;
  // Hands the lock to the caller (closing the fd releases it); the object then holds none.
  int release();

 private:
  int fd_ = -1;
};

struct CameraFaults {
  int incomplete_frames = 0;  // the next N frames lose most of their packets
};

class GigeCamera {
 public:
  GigeCamera(GigeCameraOptions options, Clock& clock, FrameSource source = analytic_frame);
  ~GigeCamera();
  GigeCamera(const GigeCamera&) = delete;
  GigeCamera& operator=(const GigeCamera&) = delete;

  // Starts serving on 127.0.0.1:3956. Throws DeviceError when the port is taken.
  void start();
  // Stops serving: to a connected driver the camera disappears.
  void stop();
  bool running() const;

  void set_faults(const CameraFaults& f);
  void set_source(FrameSource source);
  std::uint64_t frames_filled() const { return frames_.load(); }
  const GigeCameraOptions& options() const { return options_; }

  // Our GenICam description of the camera.
  static std::string genicam_xml();

 private:
  struct Impl;
  void fill(void* buffer, std::uint32_t exposure_us, std::uint32_t gain_raw, std::uint32_t format);

  GigeCameraOptions options_;
  Clock& clock_;
  std::unique_ptr<Impl> impl_;
  mutable std::mutex mutex_;
  FrameSource source_;
  CameraFaults faults_;
  std::atomic<std::uint64_t> frames_{0};
};

}  // namespace paintlab::sim
