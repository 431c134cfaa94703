#pragma once
// The measurement camera (GenICam). Cameras apply exposure and gain in increments: the
// setters return the value the camera actually applied (read back), and every frame
// carries the applied values, which later stages must use.
#include <cstdint>
#include <optional>
#include <string>

#include "paintlab/core/cfa.h"
#include "paintlab/core/image.h"
#include "paintlab/core/result.h"

namespace paintlab::dev {

// GenICam PFNC pixel formats: monochrome, colour-filter-array (Bayer) mosaics in the four
// arrangements, and packed RGB. Names as GenICam and `paintlab devices` print them.
enum class PixelFormat {
  Mono8, Mono12, Mono16,
  BayerRG8, BayerGR8, BayerGB8, BayerBG8,
  BayerRG12, BayerGR12, BayerGB12, BayerBG12,
  BayerRG16, BayerGR16, BayerGB16, BayerBG16,
  RGB8,
};

// The Bayer colour filter array (core/cfa.h), named here as the drivers have always used it.
using paintlab::CfaPattern;
using paintlab::cfa_colour;
using paintlab::cfa_pattern_from_string;
using paintlab::to_string;

const char* to_string(PixelFormat f);
// Parses a name of to_string ("Mono16", "BayerRG12", "RGB8"); DataError listing them otherwise.
PixelFormat pixel_format_from_string(const std::string& s);
int bit_depth(PixelFormat f);        // significant bits of each value: 8, 12, 16
int channels(PixelFormat f);         // values per pixel: 3 for RGB8, else 1 (a Bayer frame is one mosaic)
CfaPattern cfa_pattern(PixelFormat f);  // None for Mono and RGB8
// The format's GenICam PFNC code (what the PixelFormat register and a buffer's header hold;
// Aravis' ARV_PIXEL_FORMAT_* values), and back (nullopt for a format paintlab does not read).
std::uint32_t pfnc_code(PixelFormat f);
std::optional<PixelFormat> pixel_format_from_pfnc(std::uint32_t code);

struct FrameMeta {
  double exposure_s = 0.0;      // applied exposure, read back from the camera
  double gain_db = 0.0;         // applied gain
  std::uint64_t frame_id = 0;   // the camera's frame (block) id
  std::uint64_t timestamp_ns = 0;  // camera timestamp
  PixelFormat format = PixelFormat::Mono16;
  // A monochrome camera behind a filter wheel: the colour channel of the filter in front when
  // the frame was taken (0 R, 1 G, 2 B; set by the measurement runner), -1 none.
  int filter = -1;
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
