#include "map_file.h"

#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"

namespace fs = std::filesystem;

namespace paintlab::calib {

std::string map_plane_name(const std::string& base, int c, int channels) {
  static const char* const kSuffix[3] = {".R", ".G", ".B"};
  return channels == 1 ? base : base + kSuffix[c];
}

void add_map_planes(ExrImage& maps, const std::string& base, const ImageF& image) {
  const int C = image.channels();
  for (int c = 0; c < C; ++c) {
    ImageF plane(image.width(), image.height(), 1);
    for (std::size_t p = 0; p < plane.size(); ++p) plane.data()[p] = image.data()[p * C + c];
    maps.add(map_plane_name(base, c, C), std::move(plane));
  }
}

void read_map_planes(const ExrImage& maps, const std::string& base, ImageF& image) {
  const int C = image.channels();
  for (int c = 0; c < C; ++c) {
    const ImageF& plane = maps.plane(map_plane_name(base, c, C));
    for (std::size_t p = 0; p < plane.size(); ++p) image.data()[p * C + c] = plane.data()[p];
  }
}

WrittenMaps write_map_file(const fs::path& json_path, ExrImage maps, const std::string& kind) {
  const fs::path exr_path = fs::path(json_path).replace_extension(".exr");
  maps.attributes["paintlab.kind"] = kind;
  write_exr(exr_path, maps);
  return {exr_path.filename().string(), sha256_file(exr_path)};
}

MapRecord read_map_record(const fs::path& json_path) {
  MapRecord r;
  r.json = read_json_file(json_path);
  r.where = json_path.string();
  const Json& j = r.json;
  if (j.contains("provenance")) r.provenance = Provenance::from_json(j.at("provenance"), r.where);
  r.width = json_get<int>(j, "width", r.where);
  r.height = json_get<int>(j, "height", r.where);
  r.channels = json_get<int>(j, "channels", r.where);
  if (r.width <= 0 || r.height <= 0 || (r.channels != 1 && r.channels != 3))
    throw DataError(r.where + ": bad width, height or channels");
  r.frame_count = json_get<int>(j, "frame_count", r.where);
  r.exposures_s = json_get<std::vector<double>>(j, "exposures_s", r.where);
  r.maps = read_map_file(json_path, j, r.width, r.height);
  return r;
}

ImageF MapRecord::map(const std::string& base) const {
  ImageF image(width, height, channels);
  read_map_planes(maps, base, image);
  return image;
}

ExrImage read_map_file(const fs::path& json_path, const Json& j, int width, int height) {
  const std::string where = json_path.string();
  if (!j.contains("maps")) throw DataError(where + ": missing key 'maps'");
  const Json& ref = j.at("maps");
  const fs::path exr_path = json_path.parent_path() / json_get<std::string>(ref, "file", where);
  const std::string sha = json_get<std::string>(ref, "sha256", where);
  if (!fs::exists(exr_path)) throw DataError(where + ": its map file " + exr_path.string() + " is missing");
  if (sha256_file(exr_path) != sha)
    throw DataError(where + ": its map file " + exr_path.string() + " does not match the recorded SHA-256");
  ExrImage maps = read_exr(exr_path);
  if (maps.width != width || maps.height != height)
    throw DataError(fmt::format("{}: {}x{} maps, the JSON says {}x{}", exr_path.string(), maps.width, maps.height, width,
                                height));
  return maps;
}

}  // namespace paintlab::calib
