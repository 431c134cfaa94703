#pragma once
// The measurement camera (GenICam). Cameras apply exposure and gain in increments: the
// setters return the value the camera actually applied (read back), and every frame
// carries the applied values, which later stages must use.
#include <cstdint>
#include <string>

#include "paintlab/core/image.h"
#include "paintlab/core/result.h"

namespace paintlab::dev {

enum class PixelFormat { Mono8, Mono12, Mono16 };

const char* to_string(PixelFormat f);
// Parses "Mono8", "Mono12", "Mono16"; throws ConfigError-free DataError otherwise.
PixelFormat pixel_format_from_string(const std::string& s);
int bit_depth(PixelFormat f);  // 8, 12, 16

struct FrameMeta {
  double exposure_s = 0.0;      // applied exposure, read back from the camera
  double gain_db = 0.0;         // applied gain
  std::uint64_t frame_id = 0;   // the camera's frame (block) id
  std::uint64_t timestamp_ns = 0;  // camera timestamp
  PixelFormat format = PixelFormat::Mono16;
};

struct Frame {
  Image<std::uint16_t> pixels;  // raw values, bit_depth(meta.format) significant bits
  FrameMeta meta;
};

struct ExposureRange {
  double min_s = 0.0;
  double max_s = 0.0;
};

class Camera {
 public:
  virtual ~Camera() = default;
  virtual std::string id() const = 0;      // kind and address ("camera aravis 127.0.0.1")
  virtual std::string serial() const = 0;  // device serial number
  virtual Result<ExposureRange> exposure_range() = 0;
  // Sets the exposure time; returns the applied value (s) read back from the camera.
  virtual Result<double> set_exposure(double seconds) = 0;
  // Sets the gain; returns the applied value (dB).
  virtual Result<double> set_gain_db(double gain_db) = 0;
  virtual Result<void> set_pixel_format(PixelFormat format) = 0;
  virtual Result<PixelFormat> pixel_format() = 0;
  // Sensor readout time of one frame after its exposure (s), from the device or the rig
  // config: the physical minimum a bracket needs is sum(exposure) + n * readout.
  virtual double readout_s() const = 0;
  // Triggers one frame (software trigger) and waits up to timeout_s for it. Incomplete
  // or damaged frames are never returned as good data.
  virtual Result<Frame> capture(double timeout_s) = 0;
};

}  // namespace paintlab::dev
