#pragma once
// One way to name an enum's values in files, options and messages and to read them back:
// each enum has one table of {value, name} pairs, and to_string / *_from_string are one line
// over it. A name read that is not in the table is a DataError that names where it came
// from and every name allowed.
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>

#include "paintlab/core/error.h"

namespace paintlab {

template <class E, std::size_t N>
using EnumNames = std::array<std::pair<E, const char*>, N>;

// The name of `value`; `fallback` for a value the table lacks (an int cast to the enum).
template <class E, std::size_t N>
constexpr const char* enum_name(const EnumNames<E, N>& names, E value, const char* fallback = "?") noexcept {
  for (const auto& [v, name] : names)
    if (v == value) return name;
  return fallback;
}

// "a, b or c": the names allowed, for messages.
template <class E, std::size_t N>
std::string enum_choices(const EnumNames<E, N>& names) {
  std::string out;
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) out += i + 1 == N ? " or " : ", ";
    out += names[i].second;
  }
  return out;
}

// The value named `text`. DataError "WHERE: unknown WHAT 'TEXT' (expected a, b or c)" when no
// name matches (WHERE left out when empty: the file and key, or the option the user typed).
template <class E, std::size_t N>
E enum_from_name(const EnumNames<E, N>& names, std::string_view text, std::string_view what,
                 std::string_view where = {}) {
  for (const auto& [v, name] : names)
    if (text == name) return v;
  std::string message;
  if (!where.empty()) message.append(where).append(": ");
  message.append("unknown ").append(what).append(" '").append(text).append("' (expected ");
  message.append(enum_choices(names)).append(")");
  throw DataError(message);
}

}  // namespace paintlab
