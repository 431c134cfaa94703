#pragma once
// The per-pixel maps of dark.json and flat.json: an EXR file beside the JSON (same name,
// .exr), one float plane per map and channel ("bias", or "bias.R", "bias.G", "bias.B"), named
// in the JSON's "maps" object with its SHA-256 so that a map of another calibration is caught.
#include <filesystem>
#include <string>

#include "paintlab/calibration/record.h"
#include "paintlab/core/image.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

// The plane of channel `c` of an image with `channels` channels: `base`, or base.R/.G/.B.
std::string map_plane_name(const std::string& base, int c, int channels);

// Adds the channels of the interleaved `image` to `maps` as planes named after `base`.
void add_map_planes(ExrImage& maps, const std::string& base, const ImageF& image);

// Fills the interleaved `image` (its size and channels already set) from the planes of `base`.
void read_map_planes(const ExrImage& maps, const std::string& base, ImageF& image);

struct WrittenMaps {
  std::string file;  // the EXR's file name (beside the JSON)
  std::string sha256;
};
// Writes `maps` (its "paintlab.kind" attribute set to `kind`) beside `json_path` with
// extension .exr.
WrittenMaps write_map_file(const std::filesystem::path& json_path, ExrImage maps, const std::string& kind);

// Writes `maps` beside `json_path` (write_map_file), then the JSON that names them,
// `record.to_json(file, sha256)`.
template <class Record>
void save_map_record(const std::filesystem::path& json_path, ExrImage maps, const std::string& kind,
                     const Record& record) {
  const WrittenMaps written = write_map_file(json_path, std::move(maps), kind);
  write_json_file(json_path, record.to_json(written.file, written.sha256));
}

// What dark.json and flat.json share: the file, its provenance, the maps' size and the frames
// they were made from.
struct MapRecord {
  Json json;
  std::string where;  // the JSON file, for messages
  Provenance provenance;
  int width = 0, height = 0, channels = 0;
  int frame_count = 0;
  std::vector<double> exposures_s;
  ExrImage maps;  // the EXR the JSON names, checked against its SHA-256 and size

  // Copies the provenance, frame count and exposures into a DarkFrame or FlatField.
  template <class Calibration>
  void fill(Calibration& c) const {
    c.provenance = provenance;
    c.frame_count = frame_count;
    c.exposures_s = exposures_s;
  }
  // The value of `key` in the JSON; DataError naming the file and key.
  template <class T>
  T get(const std::string& key) const {
    return json_get<T>(json, key, where);
  }
  // The map `base` (width x height x channels) from its planes.
  ImageF map(const std::string& base) const;
};
// Reads `json_path` and the maps it names: DataError naming it when a key is missing, the size
// is not positive with 1 or 3 channels, or the maps do not match (read_map_file).
MapRecord read_map_record(const std::filesystem::path& json_path);

// Reads the maps `j["maps"]` names beside `json_path`: DataError naming the JSON when the key,
// the file or its recorded SHA-256 is missing or wrong, or the maps are not width x height.
ExrImage read_map_file(const std::filesystem::path& json_path, const Json& j, int width, int height);

}  // namespace paintlab::calib
