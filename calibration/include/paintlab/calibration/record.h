#pragma once
// The provenance block every calibration file carries: what kind of calibration, when,
// by which software, from which inputs (with SHA-256 checksums) and devices (serials),
// so `paintlab check` can tell a stale or foreign calibration from a current one.
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/core/json.h"

namespace paintlab::calib {

struct InputFile {
  std::string path;    // as given (relative to the calibration folder when inside it)
  std::string sha256;
};

struct Provenance {
  std::string kind;                      // "intrinsics", "response", "dark", ...
  std::string date;                      // UTC ISO 8601
  std::string software_version;
  std::vector<InputFile> inputs;
  Json devices = Json::object();         // {"camera": "serial", ...}

  // kind + now + this software + checksums of `files`.
  static Provenance make(const std::string& kind, const std::vector<std::filesystem::path>& files,
                         Json devices = Json::object());
  Json to_json() const;
  static Provenance from_json(const Json& j, const std::string& where);  // DataError names `where`
  // Age in days relative to now (negative if from the future); NaN if the date is malformed.
  double age_days() const;
};

// Standard file names inside the rig's calibration folder (DESIGN.md data flow).
inline constexpr const char* kCameraFile = "camera.json";
inline constexpr const char* kResponseFile = "response.json";
inline constexpr const char* kDarkFile = "dark.json";
inline constexpr const char* kFlatFile = "flat.json";
inline constexpr const char* kSphereFile = "sphere.json";
inline constexpr const char* kLightFile = "light.json";
inline constexpr const char* kScaleFile = "scale.json";
inline constexpr const char* kCheckFile = "check.json";

}  // namespace paintlab::calib
