#pragma once
// JSON files (nlohmann): reading with errors that name the file and the key, atomic
// writing, JSON Lines for journals, and Eigen conversions.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <type_traits>
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

namespace detail {

template <class T>
struct is_std_vector : std::false_type {};
template <class U, class A>
struct is_std_vector<std::vector<U, A>> : std::true_type {};

// Whether nlohmann's get<T>() can convert `v` without changing its value. Its own
// conversion is a static_cast: a number out of T's range (1e300 or -1 as a count, 1e40
// as a float) would be undefined behaviour or a silently different value. Values of
// another kind pass through: get<T>() reports them as the wrong type.
template <class T>
bool json_number_fits(const Json& v) {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    using L = std::numeric_limits<T>;
    if (v.is_number_unsigned()) return v.get_ref<const Json::number_unsigned_t&>() <= std::uintmax_t{L::max()};
    if (v.is_number_integer()) {
      const auto i = v.get_ref<const Json::number_integer_t&>();
      if constexpr (std::is_signed_v<T>) return i >= std::intmax_t{L::min()} && i <= std::intmax_t{L::max()};
      else return i >= 0 && static_cast<std::uintmax_t>(i) <= std::uintmax_t{L::max()};
    }
    if (v.is_number_float()) {
      const double d = v.get_ref<const Json::number_float_t&>();
      // T's range as doubles: min is a power of two (exact); max + 1 is one as well.
      const double hi = std::ldexp(1.0, L::digits);
      return std::isfinite(d) && std::trunc(d) == d && d >= static_cast<double>(L::min()) && d < hi;
    }
    return true;
  } else if constexpr (std::is_floating_point_v<T> && sizeof(T) < sizeof(double)) {
    if (!v.is_number_float()) return true;
    const double d = v.get_ref<const Json::number_float_t&>();
    return !std::isfinite(d) || std::fabs(d) <= static_cast<double>(std::numeric_limits<T>::max());
  } else if constexpr (is_std_vector<T>::value) {
    if (!v.is_array()) return true;
    for (const auto& e : v)
      if (!json_number_fits<typename T::value_type>(e)) return false;
    return true;
  } else {
    return true;
  }
}

}  // namespace detail

// Typed access that names `where` (usually the file) and the key in the error. A number
// that the type cannot hold (a negative or fractional count, one beyond the type's range)
// is a DataError as well, never a cast.
template <class T>
T json_get(const Json& j, std::string_view key, std::string_view where) {
  auto it = j.find(key);
  if (it == j.end()) throw DataError(std::string(where) + ": missing key '" + std::string(key) + "'");
  if (!detail::json_number_fits<T>(*it))
    throw DataError(std::string(where) + ": key '" + std::string(key) + "' holds " + it->dump().substr(0, 40) +
                    ", which is out of range for it");
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
