#include "paintlab/core/config.h"

#include <cmath>
#include <fmt/format.h>
#include <set>
#include <toml++/toml.h>

#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"

namespace paintlab {

struct ConfigTable::State {
  std::string file;
  toml::table root;
  // Keys read so far, as full dotted paths.
  std::set<std::string, std::less<>> used;
  // For a state made by with_own_usage(): the state that owns `root` and the tables.
  std::shared_ptr<const State> owner;
};

namespace {
std::string fmt_num(double v) { return fmt::format("{:g}", v); }

}  // namespace

bool Bounds::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Bounds::describe() const {
  bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return fmt::format("must be in {}{}, {}{}", lo_open ? "(" : "[", fmt_num(lo), fmt_num(hi), hi_open ? ")" : "]");
  if (has_lo) return fmt::format("must be {} {}", lo_open ? ">" : ">=", fmt_num(lo));
  if (has_hi) return fmt::format("must be {} {}", hi_open ? "<" : "<=", fmt_num(hi));
  return "must be a finite number";
}

ConfigTable::ConfigTable(std::shared_ptr<State> state, const toml::table* table, std::string prefix)
    : state_(std::move(state)), table_(table), prefix_(std::move(prefix)) {}

ConfigTable ConfigTable::parse_file(const std::filesystem::path& path) {
  auto state = std::make_shared<State>();
  state->file = path.string();
  require_readable_file(path);
  try {
    state->root = toml::parse_file(path.string());
  } catch (const toml::parse_error& e) {
    throw ConfigError(path.string(), static_cast<int>(e.source().begin.line), "",
                      std::string("TOML syntax error: ") + std::string(e.description()));
  }
  const toml::table* root = &state->root;
  return ConfigTable(state, root, "");
}

ConfigTable ConfigTable::parse_string(std::string_view text, const std::string& source_name) {
  auto state = std::make_shared<State>();
  state->file = source_name;
  try {
    state->root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(source_name, static_cast<int>(e.source().begin.line), "",
                      std::string("TOML syntax error: ") + std::string(e.description()));
  }
  const toml::table* root = &state->root;
  return ConfigTable(state, root, "");
}

const std::string& ConfigTable::file() const { return state_->file; }

std::string ConfigTable::path(std::string_view key) const {
  if (key.empty()) return prefix_;
  if (prefix_.empty()) return std::string(key);
  return prefix_ + "." + std::string(key);
}

int ConfigTable::line(std::string_view key) const {
  if (key.empty()) return static_cast<int>(table_->source().begin.line);
  if (const toml::node* n = table_->get(key)) return static_cast<int>(n->source().begin.line);
  return static_cast<int>(table_->source().begin.line);
}

bool ConfigTable::has(std::string_view key) const { return table_->contains(key); }

std::vector<std::string> ConfigTable::keys() const {
  std::vector<std::string> out;
  for (auto&& [k, v] : *table_) out.emplace_back(k.str());
  return out;
}

void ConfigTable::fail(std::string_view key, const std::string& message) const {
  throw ConfigError(state_->file, line(key), path(key), message);
}

const toml::node* ConfigTable::get(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (n) state_->used.insert(path(key));
  return n;
}

const toml::node& ConfigTable::require(std::string_view key) const {
  const toml::node* n = get(key);
  if (!n) {
    std::string where = prefix_.empty() ? "the top level" : "[" + prefix_ + "]";
    throw ConfigError(state_->file, line(), path(key), "required key is missing in " + where);
  }
  return *n;
}

void ConfigTable::accept(std::string_view key) const { state_->used.insert(path(key)); }

double ConfigTable::checked_number(std::string_view key, const toml::node& node, Bounds b) const {
  double v;
  if (auto i = node.as_integer()) {
    v = static_cast<double>(i->get());
  } else if (auto f = node.as_floating_point()) {
    v = f->get();
  } else {
    fail(key, std::string("expected a number, got ") + toml_type_name(node));
  }
  if (!b.contains(v)) fail(key, b.describe() + " (got " + fmt_num(v) + ")");
  return v;
}

double ConfigTable::number(std::string_view key, Bounds b) const { return checked_number(key, require(key), b); }

double ConfigTable::number(std::string_view key, double fallback, Bounds b) const {
  const toml::node* n = get(key);
  return n ? checked_number(key, *n, b) : fallback;
}

std::optional<double> ConfigTable::maybe_number(std::string_view key, Bounds b) const {
  const toml::node* n = get(key);
  if (!n) return std::nullopt;
  return checked_number(key, *n, b);
}

std::int64_t ConfigTable::integer(std::string_view key, Bounds b) const {
  const toml::node& n = require(key);
  auto i = n.as_integer();
  if (!i) fail(key, std::string("expected an integer, got ") + toml_type_name(n));
  if (!b.contains(static_cast<double>(i->get()))) fail(key, b.describe() + " (got " + std::to_string(i->get()) + ")");
  return i->get();
}

std::int64_t ConfigTable::integer(std::string_view key, std::int64_t fallback, Bounds b) const {
  if (!table_->contains(key)) return fallback;
  return integer(key, b);
}

bool ConfigTable::boolean(std::string_view key) const {
  const toml::node& n = require(key);
  auto v = n.as_boolean();
  if (!v) fail(key, std::string("expected true or false, got ") + toml_type_name(n));
  return v->get();
}

bool ConfigTable::boolean(std::string_view key, bool fallback) const {
  if (!table_->contains(key)) return fallback;
  return boolean(key);
}

std::string ConfigTable::string(std::string_view key) const {
  const toml::node& n = require(key);
  auto v = n.as_string();
  if (!v) fail(key, std::string("expected a string, got ") + toml_type_name(n));
  return v->get();
}

std::string ConfigTable::string(std::string_view key, std::string fallback) const {
  if (!table_->contains(key)) return fallback;
  return string(key);
}

std::optional<std::string> ConfigTable::maybe_string(std::string_view key) const {
  if (!table_->contains(key)) return std::nullopt;
  return string(key);
}

namespace {
std::string join_quoted(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", \"" : "\"") + v[i] + "\"";
  return s;
}
}  // namespace

std::string ConfigTable::choice(std::string_view key, const std::vector<std::string>& allowed) const {
  std::string v = string(key);
  for (const auto& a : allowed)
    if (a == v) return v;
  fail(key, "\"" + v + "\" is not one of " + join_quoted(allowed));
}

std::string ConfigTable::choice(std::string_view key, std::string fallback, const std::vector<std::string>& allowed) const {
  if (!table_->contains(key)) return fallback;
  return choice(key, allowed);
}

std::vector<double> ConfigTable::numbers(std::string_view key, std::size_t min_count, std::size_t max_count,
                                         Bounds b) const {
  const toml::node& n = require(key);
  auto arr = n.as_array();
  if (!arr) fail(key, std::string("expected an array of numbers, got ") + toml_type_name(n));
  if (arr->size() < min_count || arr->size() > max_count) {
    std::string want = min_count == max_count ? std::to_string(min_count)
                                              : std::to_string(min_count) + ".." + std::to_string(max_count);
    fail(key, "expected " + want + " values, got " + std::to_string(arr->size()));
  }
  std::vector<double> out;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const toml::node& e = *arr->get(i);
    double v;
    if (auto iv = e.as_integer()) v = static_cast<double>(iv->get());
    else if (auto fv = e.as_floating_point()) v = fv->get();
    else fail(key, "element " + std::to_string(i) + ": expected a number, got " + toml_type_name(e));
    if (!b.contains(v)) fail(key, "element " + std::to_string(i) + " " + b.describe() + " (got " + fmt_num(v) + ")");
    out.push_back(v);
  }
  return out;
}

std::array<double, 3> ConfigTable::triple(std::string_view key, Bounds b) const {
  auto v = numbers(key, 3, 3, b);
  return {v[0], v[1], v[2]};
}

ConfigTable ConfigTable::table(std::string_view key) const {
  const toml::node& n = require(key);
  auto t = n.as_table();
  if (!t) fail(key, std::string("expected a table, got ") + toml_type_name(n));
  return ConfigTable(state_, t, path(key));
}

ConfigTable ConfigTable::with_own_usage() const {
  auto state = std::make_shared<State>();
  state->file = state_->file;
  state->owner = state_;
  return ConfigTable(state, table_, prefix_);
}

std::optional<ConfigTable> ConfigTable::maybe_table(std::string_view key) const {
  if (!table_->contains(key)) return std::nullopt;
  return table(key);
}

std::vector<ConfigTable> ConfigTable::tables(std::string_view key, std::size_t min_count, std::size_t max_count) const {
  std::vector<ConfigTable> out;
  const toml::node* n = get(key);
  if (!n) {
    if (min_count > 0) require(key);
    return out;
  }
  auto arr = n->as_array();
  if (!arr || !arr->is_array_of_tables())
    fail(key, std::string("expected an array of tables ([[") + std::string(key) + "]]), got " + toml_type_name(*n));
  if (arr->size() < min_count || arr->size() > max_count)
    fail(key, "expected " + std::to_string(min_count) + ".." + std::to_string(max_count) + " entries, got " +
                  std::to_string(arr->size()));
  for (std::size_t i = 0; i < arr->size(); ++i)
    out.push_back(ConfigTable(state_, arr->get(i)->as_table(), path(key) + "[" + std::to_string(i) + "]"));
  return out;
}

void ConfigTable::finish() const {
  for (auto&& [k, v] : *table_) {
    std::string full = path(k.str());
    if (!state_->used.count(full)) {
      std::string where = prefix_.empty() ? "at the top level" : "in [" + prefix_ + "]";
      throw ConfigError(state_->file, static_cast<int>(v.source().begin.line), full, "unknown key " + where);
    }
  }
}

const char* toml_type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

}  // namespace paintlab
