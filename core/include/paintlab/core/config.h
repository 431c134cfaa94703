#pragma once
// TOML configuration reading (toml++) where every error names the file, the line and the
// full key. A ConfigTable remembers which keys were read; finish() rejects the rest, so a
// misspelt key is an error instead of a silently ignored setting.
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace toml {
inline namespace v3 {
class table;
class node;
}  // namespace v3
}  // namespace toml

namespace paintlab {

// What a TOML value is, for messages: "a table", "an array", "a string", "an integer", "a number",
// "a boolean", "a date", "a time" or "a date-time".
const char* toml_type_name(const toml::node& n);

// Allowed range of a number. Messages print the rule ("must be > 0").
struct Bounds {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  static Bounds any() { return {}; }
  static Bounds positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Bounds non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Bounds closed(double lo, double hi) { return {lo, hi, false, false}; }
  static Bounds open(double lo, double hi) { return {lo, hi, true, true}; }
  static Bounds at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }

  bool contains(double v) const;
  std::string describe() const;  // "must be in (0, 1)"
};

class ConfigTable {
 public:
  // Parses a TOML file; a syntax error becomes a ConfigError with its line.
  static ConfigTable parse_file(const std::filesystem::path& path);
  // Parses TOML text; `source_name` stands for the file name in messages.
  static ConfigTable parse_string(std::string_view text, const std::string& source_name);

  const std::string& file() const;
  // Full dotted key of `key` inside this table ("devices.camera.gain_db").
  std::string path(std::string_view key) const;
  // Source line of `key` (or of this table when key is empty); 0 when unknown.
  int line(std::string_view key = {}) const;
  bool has(std::string_view key) const;
  std::vector<std::string> keys() const;

  double number(std::string_view key, Bounds b = {}) const;
  double number(std::string_view key, double fallback, Bounds b) const;
  std::optional<double> maybe_number(std::string_view key, Bounds b = {}) const;
  std::int64_t integer(std::string_view key, Bounds b = {}) const;
  std::int64_t integer(std::string_view key, std::int64_t fallback, Bounds b) const;
  bool boolean(std::string_view key) const;
  bool boolean(std::string_view key, bool fallback) const;
  std::string string(std::string_view key) const;
  std::string string(std::string_view key, std::string fallback) const;
  std::optional<std::string> maybe_string(std::string_view key) const;
  // A string that must be one of `allowed`.
  std::string choice(std::string_view key, const std::vector<std::string>& allowed) const;
  std::string choice(std::string_view key, std::string fallback, const std::vector<std::string>& allowed) const;
  // An array of numbers with min_count..max_count entries, each within b.
  std::vector<double> numbers(std::string_view key, std::size_t min_count, std::size_t max_count,
                              Bounds b = {}) const;
  std::array<double, 3> triple(std::string_view key, Bounds b = {}) const;

  ConfigTable table(std::string_view key) const;
  std::optional<ConfigTable> maybe_table(std::string_view key) const;
  // An array of tables ([[key]]) with min_count..max_count entries.
  std::vector<ConfigTable> tables(std::string_view key, std::size_t min_count, std::size_t max_count) const;

  // Marks a key as read without reading it (for keys handled elsewhere).
  void accept(std::string_view key) const;
  // The same table with its own, empty record of read keys: a second reader of a table
  // that another reader accepted wholesale (a device section of rig.toml) can still
  // reject unknown keys with finish(). Keeps the parsed document alive.
  ConfigTable with_own_usage() const;
  // Throws a ConfigError naming the first key of this table that was never read.
  void finish() const;
  // Throws a ConfigError for `key` with `message` (file, line and full key filled in).
  [[noreturn]] void fail(std::string_view key, const std::string& message) const;

  const toml::table& raw() const { return *table_; }

 private:
  struct State;
  ConfigTable(std::shared_ptr<State> state, const toml::table* table, std::string prefix);
  const toml::node* get(std::string_view key) const;
  const toml::node& require(std::string_view key) const;
  double checked_number(std::string_view key, const toml::node& node, Bounds b) const;

  std::shared_ptr<State> state_;
  const toml::table* table_;
  std::string prefix_;
};

}  // namespace paintlab
