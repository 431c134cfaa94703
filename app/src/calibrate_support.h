#pragma once
// What `paintlab calibrate` and `paintlab check` share: images from files or captured
// through the rig's devices, linearised with the rig's response/dark/flat; the "stage"
// that puts a target in front of the camera (a technician at the keyboard on a real rig,
// the simulator on a simulated one); the captures kept in calib/captures/ with checksums.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/chessboard.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"
#include "rig_devices.h"

namespace paintlab::app {

// What stands on the turntable.
enum class Target {
  Sample,          // the sphere to be measured (whatever is mounted)
  WhiteReference,  // the white diffuse reference sphere (sphere pose and scale)
  GlossySphere,    // a glossy black or mirror sphere (LED positions)
};
const char* to_string(Target t);

class Stage {
 public:
  virtual ~Stage() = default;
  // Chessboard view `index` of `count` in front of the camera.
  virtual void show_board(int index, int count, const calib::BoardSpec& board) = 0;
  virtual void mount(Target target) = 0;
  // The reference's certified albedo when the stage knows it (the simulator), else 0.
  virtual double known_albedo() const { return 0.0; }
};

// Opened devices, the radiometric calibration to linearise with, the device serials.
struct CalibSession {
  RigConfig rig;
  std::unique_ptr<RigDevices> devices;
  std::unique_ptr<Stage> stage;
  acq::HdrCalibration hdr;
  Json serials = Json::object();
  int bit_depth = 16;
  std::vector<std::filesystem::path> captured;  // files saved by this session
  std::map<std::string, double> last_exposure_s;  // per step and LED state: where auto-exposure starts

  dev::Camera& camera() { return *devices->camera; }
};

// Opens the rig's devices (simulated peers for kind "sim") and the stage that goes with
// them. albedo: the reference's albedo for a simulated stage (0: 0.99).
CalibSession open_calib_session(const RigConfig& rig, double albedo);
// Loads response/dark/flat that exist (for files given with --images, no devices).
acq::HdrCalibration load_radiometry(const RigConfig& rig);

// One image ready for the geometric steps: linear values per second (DN/s), the pixels
// that were clipped, and where it came from.
struct Shot {
  std::string name;
  std::filesystem::path file;            // the capture or input file
  Image<std::uint16_t> raw;              // empty for EXR inputs
  int bit_depth = 16;
  ImageF rate;                           // linearised DN per second
  Image<std::uint8_t> saturated;         // 1 = clipped
  double exposure_s = 0.0;
  bool per_second = false;               // rate is per second (captured, EXR, or exposure in the name)
  std::optional<double> table_angle_deg;
};

// Moves the table (wrapped to [0, 360)), switches the LED, finds an exposure that puts the
// `quantile` pixel at `fill` of the range, captures, linearises and saves the frame under
// calib/captures/<step>/<name>.png.
// With `exposure_s` set, that exposure is used as it is.
Shot capture_shot(CalibSession& s, const std::string& step, const std::string& name, std::optional<double> angle_deg,
                  bool led_on, double fill, double quantile, std::optional<double> exposure_s = std::nullopt);

// Input files: directories expand to their image files (sorted); angles and exposures are
// read from names like `light_angle-150_exp2.5ms.png` (tokens angle<number>, exp<number>ms|us|s).
std::vector<std::filesystem::path> expand_inputs(const std::vector<std::string>& args, const std::string& option);
std::optional<double> angle_from_name(const std::string& name);
std::optional<double> exposure_from_name(const std::string& name);
// PNG/TIFF/JPEG (raw values, linearised; per second when the name carries the exposure) or
// EXR (channel Y in DN/s as `paintlab hdr merge` writes it, `valid` marks good pixels).
Shot load_shot(const std::filesystem::path& file, const acq::HdrCalibration& hdr);

// Device identities recorded in provenance: {"camera": serial, "turntable": id, "light": id}
// (turntable and light: kind and address, left out for simulated peers).
Json device_serials(RigDevices& d, const RigConfig& rig);

// `paintlab calibrate all` runs every registered step in `order` (intrinsics 10, dark 20,
// response 30, flat 40, sphere 50, light 60, scale 70). A step reads its images from
// `images_dir / name` when given, else captures through `session`.
struct CalibrateContext {
  RigConfig rig;
  CalibSession* session = nullptr;                 // capturing
  std::optional<std::filesystem::path> images_dir;  // or images from files
  double albedo = 0.0;                              // the reference's (scale)
  std::string k3;                                   // intrinsics: "fix", "free", or empty (decided from the data)
};
struct CalibrateStep {
  std::string name;
  int order = 0;
  std::function<void(CalibrateContext&)> run;
};
void register_calibration_step(CalibrateStep step);
const std::vector<CalibrateStep>& calibration_steps();

}  // namespace paintlab::app
