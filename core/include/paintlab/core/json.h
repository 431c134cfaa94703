#pragma once
// JSON files (nlohmann): reading with errors that name the file and the key, atomic
// writing, JSON Lines for journals, and Eigen conversions.
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/core/error.h"

namespace paintlab {

using Json = nlohmann::json;

// Reads and parses a JSON file. Throws IoError (cannot read) or DataError
// ("FILE: not valid JSON at byte N: ...").
Json read_json_file(const std::filesystem::path& path);
// Writes atomically (temp + fsync + rename), pretty-printed, newline-terminated.
void write_json_file(const std::filesystem::path& path, const Json& value);

// Reads a JSON Lines file. A final line without newline that does not parse is a torn
// append (a crash mid-write): it is dropped and *torn_tail is set; any other bad line
// is a DataError naming FILE:LINE.
std::vector<Json> read_jsonl_file(const std::filesystem::path& path, bool* torn_tail = nullptr);
// Appends one line and fsyncs it (a journal entry is durable when this returns).
void append_jsonl_line(const std::filesystem::path& path, const Json& value);

// Typed access that names `where` (usually the file) and the key in the error.
template <class T>
T json_get(const Json& j, std::string_view key, std::string_view where) {
  auto it = j.find(key);
  if (it == j.end()) throw DataError(std::string(where) + ": missing key '" + std::string(key) + "'");
  try {
    return it->template get<T>();
  } catch (const nlohmann::json::exception& e) {
    throw DataError(std::string(where) + ": key '" + std::string(key) + "' has the wrong type (" +
                    std::string(it->type_name()) + ")");
  }
}

template <class T>
T json_get_or(const Json& j, std::string_view key, T fallback, std::string_view where) {
  if (!j.contains(key)) return fallback;
  return json_get<T>(j, key, where);
}

Json matrix_to_json(const Eigen::MatrixXd& m);              // row-major nested arrays
Eigen::MatrixXd matrix_from_json(const Json& j, std::string_view what);  // DataError on shape
Json vector3_to_json(const Eigen::Vector3d& v);
Eigen::Vector3d vector3_from_json(const Json& j, std::string_view what);

}  // namespace paintlab
