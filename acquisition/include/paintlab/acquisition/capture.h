#pragma once
// Capturing single frames and exposure stacks for the calibration steps and the rig check
// (docs/calibration.md, docs/radiometry.md): what stands in front of the camera (a Stage),
// one auto-exposure loop, the LED switched off on every path, frames linearised with the
// rig's response/dark/flat, and the captures saved with their exposures. Everything here
// sees only the device interfaces (devices/*.h) and a Clock; app/ chooses the drivers and
// the stage (the simulator or a technician at the console).
#include <array>
#include <functional>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/chessboard.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/core/clock.h"
#include "paintlab/core/image.h"
#include "paintlab/devices/camera.h"
#include "paintlab/devices/filter_wheel.h"
#include "paintlab/devices/light.h"
#include "paintlab/devices/turntable.h"

namespace paintlab::acq {

// ---- What stands in front of the camera ----

// What stands on the turntable.
enum class Target {
  Sample,          // the sphere to be measured (whatever is mounted)
  WhiteReference,  // the white diffuse reference sphere (sphere pose, response, scale)
  GlossySphere,    // a glossy black or mirror sphere (LED positions)
};
const char* to_string(Target t);  // "the white reference sphere", ...

// What is in front of the lens.
enum class LensView {
  Scene,     // nothing: the camera sees the rig
  Capped,    // the lens cap (dark frames)
  Diffuser,  // a uniform diffuser over the lens, or a uniformly lit white target filling the view (flat field)
};
const char* to_string(LensView v);

// Puts targets in front of the camera: a technician prompted at the console on a real rig,
// the simulator on a simulated one. Each call returns when the target is in place.
class Stage {
 public:
  virtual ~Stage() = default;
  // Chessboard view `index` of `count` in front of the camera.
  virtual void show_board(int index, int count, const calib::BoardSpec& board) = 0;
  virtual void mount(Target target) = 0;
  virtual void cover_lens(LensView view) = 0;
  // A colour chart (ColorChecker 24) facing the camera, in view and evenly lit, until
  // mount() or cover_lens() changes the scene.
  virtual void show_chart() = 0;
  // The reference's certified albedo when the stage knows it (the simulator), else 0.
  virtual double known_albedo() const { return 0.0; }
};

// ---- Auto exposure ----

// One rule for how long a capture may take: the exposure and the readout with room for a
// slow link (seconds).
double capture_timeout_s(double exposure_s);

// The raw value below which a fraction `q` of the pixels lie (q in [0, 1], nearest rank,
// rounding down). Every 4th pixel is looked at, except for q >= 0.9999 (the top of the
// range: every pixel counts) and for images under 4096 pixels.
double raw_quantile(const Image<std::uint16_t>& image, double q);

struct AutoExposureOptions {
  double fill = 0.6;        // the `quantile` pixel at this share of the range above black, (0, 0.97)
  double quantile = 0.999;  // [0, 1]
  double black_dn = 0.0;    // black level of the raw values, >= 0
  // Done when the next exposure would differ from the applied one by less than this
  // ratio, (0, 1).
  double tolerance = 0.1;
  double start_s = 0.01;  // first trial (clamped to the camera's range), > 0
  int max_frames = 12;    // trial frames at most, >= 1
  void check() const;     // UsageError naming the field, its value and the rule
};

struct AutoExposure {
  double exposure_s = 0.0;  // applied, as read back from the camera
  dev::Frame frame;         // the last trial frame (taken at exposure_s)
  int frames = 0;           // trial frames taken
  double level = 0.0;       // the quantile pixel's share of the range in that frame
  // false when the search stopped at an end of the camera's range or after max_frames.
  bool converged = false;
};

// Finds an exposure at which the `quantile` raw value lies at `fill` of the range above
// `black_dn` (the light as it is): a saturated frame divides the exposure by 8, a black one
// multiplies it by 16, otherwise it scales by fill / level. DeviceError when the camera
// fails.
AutoExposure auto_expose(dev::Camera& camera, const AutoExposureOptions& options);

// ---- The LED ----

// Switches the light on or off and switches it off again when it dies, on every path
// (an exception, an early return). Errors switching it off in the destructor are logged.
class LightSwitch {
 public:
  LightSwitch(dev::Light& light, bool on);
  ~LightSwitch();
  LightSwitch(const LightSwitch&) = delete;
  LightSwitch& operator=(const LightSwitch&) = delete;
  // Switches it off now (DeviceError when that fails).
  void off();

 private:
  dev::Light* light_;
  bool on_ = false;
};

// ---- Exposure stacks (radiometric calibration) ----

// Captures `repeats` frames at each of `exposures_s` with the LED on or off (the table stays
// where it is) at `gain_db`, and saves them as PNG, with exposures.txt, in `save_dir`, which
// then works as `--images save_dir`. The stack holds the exposures the camera applied. The
// LED is off afterwards on every path. DeviceError when a device fails.
// The camera channel (0 R, 1 G, 2 B) of each pixel of a Bayer format's top-left 2x2 block,
// row by row (calibration's form of dev::cfa_pattern); unset for Mono and RGB formats.
std::optional<std::array<int, 4>> cfa_sites(dev::PixelFormat format);

calib::ExposureStack capture_stack(dev::Camera& camera, dev::Light& light, double gain_db,
                                   const std::vector<double>& exposures_s, int repeats, bool light_on,
                                   const std::filesystem::path& save_dir);

// ---- Linear frames ----

// Turns raw frames into linear DN per second with the rig's response, dark and flat
// (acq::HdrMerger on a stack of one). Building a merger tabulates the response and noise
// at every raw value, which costs more than merging a frame, so the linearizer keeps the
// one it built for the last frame geometry and bit depth and rebuilds it only when those
// or the calibration change.
class Linearizer {
 public:
  explicit Linearizer(HdrCalibration calibration = {});
  const HdrCalibration& calibration() const { return calibration_; }
  // A recalibrated response/dark/flat: the next frame builds a new merger.
  void set_calibration(HdrCalibration calibration);

  struct Linear {
    ImageF rate;                    // linear DN per second
    Image<std::uint8_t> saturated;  // 1 = clipped (at the merge's saturation, at most 99.5 % of full scale)
  };
  Linear linearise(const Image<std::uint16_t>& raw, int bit_depth, double exposure_s);
  int mergers_built() const { return mergers_built_; }

 private:
  HdrCalibration calibration_;
  std::unique_ptr<HdrMerger> merger_;
  int width_ = 0, height_ = 0, bit_depth_ = 0;
  int mergers_built_ = 0;
};

// ---- Shots for the geometric steps ----

// One image ready for the geometric steps: linear values per second (DN/s), the pixels that
// were clipped, and where it came from.
struct Shot {
  std::string name;
  std::filesystem::path file;  // the capture or input file
  Image<std::uint16_t> raw;    // empty for EXR inputs
  int bit_depth = 16;
  ImageF rate;                    // linearised DN per second (a colour camera: its luminance, R/4 + G/2 + B/4)
  Image<std::uint8_t> saturated;  // 1 = clipped (a colour camera: any site the pixel's colours use)
  // A colour-filter-array camera's shot: the filter arrangement of `raw` (a mosaic) and the
  // linear camera RGB per second at every pixel (bilinear demosaicing); empty otherwise.
  dev::CfaPattern cfa = dev::CfaPattern::None;
  ImageF rgb;
  double blur_var_px2 = 0.0;  // blur `rate` has beyond the camera's (the luminance filter's: 0.5 px^2)
  double exposure_s = 0.0;
  bool per_second = false;  // rate is per second (captured, EXR, or exposure in the name)
  std::optional<double> table_angle_deg;
};

// The mean of the channels, rounded (a colour frame seen as one channel).
Image<std::uint16_t> to_mono(const Image<std::uint16_t>& image);

// Angle and exposure from file names like `light_angle-150_exp2.5ms.png` (tokens
// angle<number> and exp<number>ms|us|s, case-insensitive; seconds in the result).
std::optional<double> angle_from_name(const std::string& name);
std::optional<double> exposure_from_name(const std::string& name);

// PNG/TIFF/JPEG/PGM (raw values, linearised; per second when the name carries the exposure)
// or EXR (channel Y in DN/s as `paintlab hdr merge` writes it, `valid` marks good pixels).
Shot load_shot(const std::filesystem::path& file, Linearizer& linearizer);

struct ShotRequest {
  std::string step;                 // calibration step: captures/<step>/, and the auto-exposure memory
  std::string name;                 // file name without extension
  std::optional<double> angle_deg;  // move the table there first (wrapped to [0, 360))
  bool led_on = false;
  double fill = 0.6;  // auto exposure (AutoExposureOptions)
  double quantile = 0.999;
  std::optional<double> exposure_s;  // use this exposure as it is instead
};

// Captures the shots of the calibration steps through the rig's devices: moves the table,
// switches the LED (off again on every path), finds the exposure (starting from where the
// step's previous shot with the same LED state ended: consecutive shots of a step see the
// same target and light, so one frame is usually enough), linearises the frame and saves it
// as 16-bit PNG under `captures_dir/<step>/<name>.png`.
class ShotCapture {
 public:
  struct Devices {
    dev::Turntable* table = nullptr;  // may be null: then no request may ask for an angle
    dev::Light* light = nullptr;
    dev::Camera* camera = nullptr;
    Clock* clock = nullptr;
    // A monochrome camera behind a filter wheel: every shot is taken once per filter (each
    // auto-exposed on its own) and becomes a colour shot: `rgb` the three per-second images,
    // `rate` their luminance (R + 2 G + B) / 4, `saturated` where any of them clipped.
    dev::FilterWheel* wheel = nullptr;
    std::array<int, 3> wheel_slots{1, 2, 3};  // R, G, B
  };
  // `settle_s`: wait after each move (the plan's settle time); `tolerance`: the
  // auto-exposure tolerance (AutoExposureOptions::tolerance).
  ShotCapture(Devices devices, std::filesystem::path captures_dir, double settle_s, double tolerance = 0.15);

  Shot capture(const ShotRequest& request, Linearizer& linearizer);
  // Every file saved so far, in capture order.
  const std::vector<std::filesystem::path>& captured() const { return captured_; }

 private:
  Devices d_;
  std::filesystem::path dir_;
  double settle_s_;
  double tolerance_;
  int bit_depth_ = 0;
  std::map<std::string, double> last_exposure_s_;  // per step and LED state
  std::vector<std::filesystem::path> captured_;
  // A colour camera's gains (acq::grey_gains), from the last shot that showed enough grey.
  std::optional<std::array<double, 3>> cfa_gains_;
  Shot capture_through_wheel(const ShotRequest& request, Linearizer& linearizer,
                             const std::function<dev::Frame(const std::string&)>& take);
};

}  // namespace paintlab::acq
