#include "paintlab/brdf/paint.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <set>
#include <toml++/toml.h>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab::brdf {

namespace {

const char* const kCookTorrance = "cook-torrance";
const char* const kAxf = "axf-carpaint";
const char* const kPearl = "layered-pearlescent";
const char* const kMerl = "merl";
const char* const kCosine = "cosine-lobes";

// The JSON twin of ConfigTable: the same reading functions, so one template parses both
// formats with the same rules. Errors: "WHERE: key 'PATH': RULE".
class JsonTable {
 public:
  JsonTable(const Json* j, std::string where, std::string prefix, bool strict,
            std::shared_ptr<std::set<std::string>> used = std::make_shared<std::set<std::string>>())
      : j_(j), where_(std::move(where)), prefix_(std::move(prefix)), strict_(strict), used_(std::move(used)) {}

  std::string path(std::string_view key) const {
    return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
  }
  [[noreturn]] void fail(std::string_view key, const std::string& message) const {
    throw DataError(where_ + ": key '" + path(key) + "': " + message);
  }
  bool has(std::string_view key) const { return j_->contains(key); }

  double number(std::string_view key, Bounds b) const { return checked(key, require(key), b); }
  double number(std::string_view key, double fallback, Bounds b) const {
    const Json* n = get(key);
    return n ? checked(key, *n, b) : fallback;
  }
  std::int64_t integer(std::string_view key, Bounds b) const {
    const Json& n = require(key);
    if (!n.is_number_integer()) fail(key, std::string("expected an integer, got ") + type_name(n));
    const auto v = n.get<std::int64_t>();
    if (!b.contains(static_cast<double>(v))) fail(key, b.describe() + " (got " + std::to_string(v) + ")");
    return v;
  }
  std::int64_t integer(std::string_view key, std::int64_t fallback, Bounds b) const {
    return has(key) ? integer(key, b) : fallback;
  }
  std::string string(std::string_view key) const {
    const Json& n = require(key);
    if (!n.is_string()) fail(key, std::string("expected a string, got ") + type_name(n));
    return n.get<std::string>();
  }
  std::string string(std::string_view key, std::string fallback) const { return has(key) ? string(key) : fallback; }
  std::string choice(std::string_view key, const std::vector<std::string>& allowed) const {
    std::string v = string(key);
    if (std::find(allowed.begin(), allowed.end(), v) != allowed.end()) return v;
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "\"" : ", \"") + a + "\"";
    fail(key, "\"" + v + "\" is not one of " + list);
  }
  std::vector<double> numbers(std::string_view key, std::size_t min_count, std::size_t max_count, Bounds b) const {
    const Json& n = require(key);
    if (!n.is_array()) fail(key, std::string("expected an array of numbers, got ") + type_name(n));
    if (n.size() < min_count || n.size() > max_count) {
      std::string want = min_count == max_count ? std::to_string(min_count)
                                                : std::to_string(min_count) + ".." + std::to_string(max_count);
      fail(key, "expected " + want + " values, got " + std::to_string(n.size()));
    }
    std::vector<double> out;
    for (std::size_t i = 0; i < n.size(); ++i) {
      if (!n[i].is_number())
        fail(key, "element " + std::to_string(i) + ": expected a number, got " + type_name(n[i]));
      const double v = n[i].get<double>();
      if (!b.contains(v)) fail(key, "element " + std::to_string(i) + " " + b.describe() + " (got " + fmt::format("{:g}", v) + ")");
      out.push_back(v);
    }
    return out;
  }
  std::array<double, 3> triple(std::string_view key, Bounds b) const {
    auto v = numbers(key, 3, 3, b);
    return {v[0], v[1], v[2]};
  }
  // An array of [R, G, B] arrays (cosine-lobes' kg, kdd); values checked by the caller.
  std::vector<std::array<double, 3>> triples(std::string_view key) const {
    const Json& n = require(key);
    if (!n.is_array()) fail(key, std::string("expected an array of [R, G, B] arrays, got ") + type_name(n));
    std::vector<std::array<double, 3>> out;
    for (std::size_t i = 0; i < n.size(); ++i) {
      const Json& row = n[i];
      if (!row.is_array())
        fail(key, "element " + std::to_string(i) + ": expected an array [R, G, B], got " + type_name(row));
      if (row.size() != 3)
        fail(key, "element " + std::to_string(i) + ": expected 3 values [R, G, B], got " + std::to_string(row.size()));
      std::array<double, 3> v{};
      for (std::size_t c = 0; c < 3; ++c) {
        if (!row[c].is_number())
          fail(key, "element " + std::to_string(i) + ": expected a number at index " + std::to_string(c) + ", got " +
                        type_name(row[c]));
        v[c] = row[c].get<double>();
      }
      out.push_back(v);
    }
    return out;
  }
  std::vector<JsonTable> tables(std::string_view key, std::size_t min_count, std::size_t max_count) const {
    const Json& n = require(key);
    if (!n.is_array()) fail(key, std::string("expected an array of objects, got ") + type_name(n));
    if (n.size() < min_count || n.size() > max_count)
      fail(key, "expected " + std::to_string(min_count) + ".." + std::to_string(max_count) + " entries, got " +
                    std::to_string(n.size()));
    std::vector<JsonTable> out;
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string p = path(key) + "[" + std::to_string(i) + "]";
      if (!n[i].is_object()) throw DataError(where_ + ": key '" + p + "': expected an object, got " + type_name(n[i]));
      out.emplace_back(&n[i], where_, p, true, used_);
    }
    return out;
  }
  std::optional<JsonTable> maybe_table(std::string_view key) const {
    const Json* n = get(key);
    if (!n) return std::nullopt;
    if (!n->is_object()) fail(key, std::string("expected an object, got ") + type_name(*n));
    return JsonTable(n, where_, path(key), true, used_);
  }
  void finish() const {
    if (!strict_) return;
    for (auto it = j_->begin(); it != j_->end(); ++it)
      if (!used_->count(path(it.key())))
        fail(it.key(), "unknown key" + (prefix_.empty() ? std::string(" at the top level") : " in '" + prefix_ + "'"));
  }

 private:
  static const char* type_name(const Json& n) {
    switch (n.type()) {
      case Json::value_t::object: return "an object";
      case Json::value_t::array: return "an array";
      case Json::value_t::string: return "a string";
      case Json::value_t::boolean: return "a boolean";
      case Json::value_t::null: return "null";
      case Json::value_t::number_integer:
      case Json::value_t::number_unsigned: return "an integer";
      case Json::value_t::number_float: return "a number";
      default: return "something else";
    }
  }
  const Json* get(std::string_view key) const {
    auto it = j_->find(key);
    if (it == j_->end()) return nullptr;
    used_->insert(path(key));
    return &*it;
  }
  const Json& require(std::string_view key) const {
    const Json* n = get(key);
    if (!n) fail(key, "required key is missing");
    return *n;
  }
  double checked(std::string_view key, const Json& n, Bounds b) const {
    if (!n.is_number()) fail(key, std::string("expected a number, got ") + type_name(n));
    const double v = n.get<double>();
    if (!b.contains(v)) fail(key, b.describe() + " (got " + fmt::format("{:g}", v) + ")");
    return v;
  }

  const Json* j_;
  std::string where_;
  std::string prefix_;
  bool strict_;
  std::shared_ptr<std::set<std::string>> used_;
};

Rgb rgb_of(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

bool valid_name(const std::string& s) {
  if (s.empty()) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
}

const Bounds kUnitOpen = Bounds::open(0.0, 1.0);
// Physical ranges (docs/paint-files.md), with room for a measurement's uncertainty since
// fitted paints are read through here too: a diffuse albedo above 1 reflects more light
// than it receives (2 is refused); a lobe reflects about 4 weight F with F >= 0.025 for any
// coating (IOR >= 1.37), so a weight of 10 already does (20 is refused). A finite but absurd
// value (kd = 1e308) is an error naming file, line and key, not an image of inf.
const Bounds kAlbedo = Bounds::closed(0.0, 2.0);
const Bounds kLobeWeight = Bounds::closed(0.0, 20.0);
const Bounds kIor = Bounds::closed(1.0, 3.0);

template <class Table>
CookTorranceParams parse_cook_torrance(const Table& t) {
  CookTorranceParams p;
  p.kd = rgb_of(t.triple("kd", kAlbedo));
  for (const Table& l : t.tables("lobes", 1, 3)) {
    CtLobe lobe;
    lobe.ks = rgb_of(l.triple("ks", kLobeWeight));
    lobe.m = l.number("m", kUnitOpen);
    lobe.r = l.number("r", kUnitOpen);
    l.finish();
    p.lobes.push_back(lobe);
  }
  return p;
}

template <class Table>
AxfCarPaintParams parse_axf(const Table& t) {
  AxfCarPaintParams p;
  p.ior = t.number("ior", kIor);
  p.diffuse = t.number("diffuse", kAlbedo);
  for (const Table& l : t.tables("lobes", 1, 3)) {
    AxfLobe lobe;
    lobe.coefficient = l.number("coefficient", kLobeWeight);
    lobe.spread = l.number("spread", kUnitOpen);
    lobe.f0 = l.number("f0", kUnitOpen);
    l.finish();
    p.lobes.push_back(lobe);
  }
  if (auto c = t.maybe_table("chi")) {
    ColourTable& chi = p.chi;
    chi.theta_h_samples = static_cast<int>(c->integer("theta_h_samples", Bounds::closed(1, 1024)));
    chi.theta_i_samples = static_cast<int>(c->integer("theta_i_samples", Bounds::closed(1, 1024)));
    chi.scale = c->number("scale", 1.0, Bounds{0.0, 1000.0, true, false});
    const std::size_t n = static_cast<std::size_t>(chi.theta_h_samples) * static_cast<std::size_t>(chi.theta_i_samples);
    const std::vector<double> v = c->numbers("rgb", 3 * n, 3 * n, Bounds::closed(0.0, 100.0));
    chi.rgb.resize(n);
    for (std::size_t i = 0; i < n; ++i) chi.rgb[i] = Rgb(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    c->finish();
  }
  return p;
}

// The TOML twin of JsonTable::triples: ConfigTable reads flat arrays only, so the nested
// array is read from the parsed table itself (the key is marked as read, errors name its line).
std::vector<std::array<double, 3>> triples(const ConfigTable& t, std::string_view key) {
  if (!t.has(key)) t.fail(key, "required key is missing in the top level");
  t.accept(key);
  const toml::node& n = *t.raw().get(key);
  const toml::array* rows = n.as_array();
  if (!rows) t.fail(key, std::string("expected an array of [R, G, B] arrays, got ") + toml_type_name(n));
  std::vector<std::array<double, 3>> out;
  for (std::size_t i = 0; i < rows->size(); ++i) {
    const toml::node& r = *rows->get(i);
    const toml::array* row = r.as_array();
    if (!row) t.fail(key, "element " + std::to_string(i) + ": expected an array [R, G, B], got " + toml_type_name(r));
    if (row->size() != 3)
      t.fail(key, "element " + std::to_string(i) + ": expected 3 values [R, G, B], got " + std::to_string(row->size()));
    std::array<double, 3> v{};
    for (std::size_t c = 0; c < 3; ++c) {
      const toml::node& e = *row->get(c);
      if (auto iv = e.as_integer()) v[c] = static_cast<double>(iv->get());
      else if (auto fv = e.as_floating_point()) v[c] = fv->get();
      else
        t.fail(key, "element " + std::to_string(i) + ": expected a number at index " + std::to_string(c) + ", got " +
                        toml_type_name(e));
    }
    out.push_back(v);
  }
  return out;
}
std::vector<std::array<double, 3>> triples(const JsonTable& t, std::string_view key) { return t.triples(key); }

// A cosine lobe of exponent E and weight w at the mirror direction reflects at most about
// 2 pi w / (E + 1) of the light (the integral of (r.o)^E over the hemisphere): as for the other
// models' weights, twice the light received is refused, so w <= (E + 1) / pi. A fixed bound
// would either refuse a real clear coat (4 % at E = 4000 needs w ~ 25) or let 1e308 through.
double max_lobe_weight(double exponent) { return (exponent + 1.0) / std::numbers::pi; }

template <class Table>
CosineLobeParams parse_cosine_lobes(const Table& t) {
  CosineLobeParams p;
  p.exponents = t.numbers("exponents", 1, static_cast<std::size_t>(kMaxCosineLobes),
                          Bounds::closed(kMinLobeExponent, kMaxLobeExponent));
  for (std::size_t i = 1; i < p.exponents.size(); ++i)
    if (!(p.exponents[i] > p.exponents[i - 1]))
      t.fail("exponents", fmt::format("element {}: {:g} not above element {} = {:g} (exponents increase)", i,
                                      p.exponents[i], i - 1, p.exponents[i - 1]));
  p.kd = rgb_of(t.triple("kd", kAlbedo));
  const std::size_t n = p.exponents.size();
  for (const char* key : {"kg", "kdd"}) {
    const auto rows = triples(t, key);
    if (rows.size() != n)
      t.fail(key, fmt::format("{} entries for {} exponents (one [R, G, B] per exponent)", rows.size(), n));
    std::vector<Rgb>& out = std::string_view(key) == "kg" ? p.kg : p.kdd;
    for (std::size_t i = 0; i < n; ++i) {
      const double hi = max_lobe_weight(p.exponents[i]);
      const std::string row = fmt::format("[{:g}, {:g}, {:g}]", rows[i][0], rows[i][1], rows[i][2]);
      for (double v : rows[i]) {
        if (!(std::isfinite(v) && v >= 0))
          t.fail(key, fmt::format("element {}: {} must be finite and >= 0 (got {:g})", i, row, v));
        if (v > hi)
          t.fail(key, fmt::format("element {}: {} must be at most (E + 1) / pi = {:.4g} for exponent E = {:g}, or the "
                                  "lobe reflects more than twice the light it receives (got {:g})",
                                  i, row, hi, p.exponents[i], v));
      }
      out.push_back(rgb_of(rows[i]));
    }
  }
  // The model's own rules, which the checks above imply; kept so that the file reader can
  // never accept what CosineLobes itself calls invalid. Its problems start with the key.
  if (const std::string problem = cosine_lobes_problem(p); !problem.empty()) {
    const std::string key = problem.substr(0, problem.find_first_of("[:"));
    t.fail(key, problem);
  }
  return p;
}

template <class Table>
PearlescentParams parse_pearl(const Table& t) {
  PearlescentParams p;
  p.substrate = rgb_of(t.triple("substrate", Bounds::closed(0.0, 1.0)));
  p.ior = t.number("ior", kIor);
  p.gloss_roughness = t.number("gloss_roughness", kUnitOpen);
  if (t.has("absorption")) p.absorption = rgb_of(t.triple("absorption", Bounds::closed(0.0, 1000.0)));
  const Table g = *t.maybe_table("pigment");  // required: checked by the caller
  p.coverage = g.number("coverage", Bounds::closed(0.0, 20.0));
  p.opacity = g.number("opacity", Bounds::closed(0.0, 1.0));
  p.flake_roughness = g.number("roughness", kUnitOpen);
  p.film_ior = g.number("film_ior", Bounds{1.0, 4.0, true, false});
  p.film_thickness_nm = g.number("film_thickness_nm", Bounds{0.0, 2000.0, true, false});
  p.core_ior = g.number("core_ior", Bounds{1.0, 4.0, true, false});
  g.finish();
  return p;
}

template <class Table>
PaintSpec parse_generic(const Table& t, const fs::path& base_dir, bool name_required) {
  PaintSpec s;
  s.name = name_required ? t.string("name") : t.string("name", "unnamed");
  if (!valid_name(s.name))
    t.fail("name", "\"" + s.name + "\" is not a valid paint name (use only a-z, 0-9, '.', '_', '-')");
  const std::string model = t.choice("model", paint_models());
  std::vector<double> lobe_roughness;
  if (model == kCookTorrance) {
    auto p = parse_cook_torrance(t);
    for (const auto& l : p.lobes) lobe_roughness.push_back(l.m);
    s.params = std::move(p);
  } else if (model == kAxf) {
    auto p = parse_axf(t);
    for (const auto& l : p.lobes) lobe_roughness.push_back(l.spread);
    s.params = std::move(p);
  } else if (model == kPearl) {
    if (!t.has("pigment")) t.fail("pigment", "required table is missing (the flake pigment of the layered model)");
    s.params = parse_pearl(t);
  } else if (model == kCosine) {
    s.params = parse_cosine_lobes(t);
  } else {
    MerlParams p;
    p.table = t.string("table");
    p.resolved = fs::path(p.table).is_absolute() ? fs::path(p.table) : base_dir / p.table;
    std::error_code ec;
    if (!fs::is_regular_file(p.resolved, ec)) t.fail("table", "no such file: " + p.resolved.string());
    const auto size = fs::file_size(p.resolved, ec);
    if (ec || size != kMerlFileBytes)
      t.fail("table", fmt::format("{}: expected {} bytes, got {} (not a MERL table)", p.resolved.string(),
                                  kMerlFileBytes, ec ? 0 : size));
    s.params = std::move(p);
  }

  if (t.has("flakes")) {
    if (model == kMerl) t.fail("flakes", "sparkle needs an analytic model; not allowed with model \"merl\"");
    // The simulator's sparkle moves the energy of lobes the flakes carry into glints; cosine
    // lobes are a fitted basis with no flake orientation behind them.
    if (model == kCosine)
      t.fail("flakes", "sparkle needs lobes that flakes carry (cook-torrance, axf-carpaint or layered-pearlescent); "
                       "not allowed with model \"cosine-lobes\"");
    const Table f = *t.maybe_table("flakes");
    FlakeSpec fl;
    fl.density = f.number("density", Bounds{0.0, kMaxFlakeDensity, true, false});
    fl.roughness = f.number("roughness", kUnitOpen);
    fl.lifetime_deg = f.number("lifetime_deg", fl.lifetime_deg, Bounds{0.0, 45.0, true, false});
    fl.tint_sd = f.number("tint_sd", fl.tint_sd, Bounds::closed(0.0, 1.0));
    fl.interference = f.number("interference", fl.interference, Bounds::closed(0.0, 1.0));
    fl.interference_chroma = f.number("interference_chroma", fl.interference_chroma, Bounds{0.0, 1.0, true, false});
    fl.interference_shift_deg = f.number("interference_shift_deg", fl.interference_shift_deg, Bounds::closed(-90.0, 90.0));
    if (model == kPearl) {
      if (f.has("lobes"))
        f.fail("lobes", "layered-pearlescent has no lobes; its flakes carry the glitter term");
    } else if (f.has("lobes")) {
      const double n = static_cast<double>(lobe_roughness.size());
      const auto v = f.numbers("lobes", 1, lobe_roughness.size(), Bounds::closed(1.0, n));
      std::set<int> seen;
      for (double x : v) {
        if (x != std::floor(x)) f.fail("lobes", fmt::format("lobe numbers are whole numbers (got {:g})", x));
        const int idx = static_cast<int>(x) - 1;
        if (!seen.insert(idx).second) f.fail("lobes", fmt::format("lobe {} is listed twice", idx + 1));
        fl.lobes.push_back(idx);
      }
    } else {
      fl.lobes = default_flake_lobes(lobe_roughness);
    }
    f.finish();
    s.flakes = fl;
  }
  t.finish();
  return s;
}

// A TOML/JSON-safe number that reads back to the same double, with a decimal point or
// exponent so TOML sees a float.
std::string num(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}
std::string rgb_str(const Rgb& c) { return "[" + num(c[0]) + ", " + num(c[1]) + ", " + num(c[2]) + "]"; }
std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04X}", static_cast<unsigned>(static_cast<unsigned char>(c)));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

Json rgb_json(const Rgb& c) { return Json::array({c[0], c[1], c[2]}); }

}  // namespace

const std::vector<std::string>& paint_models() {
  static const std::vector<std::string> m{kCookTorrance, kAxf, kPearl, kMerl, kCosine};
  return m;
}

std::string PaintSpec::model() const {
  return std::visit(
      [](const auto& p) -> std::string {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, CookTorranceParams>) return kCookTorrance;
        else if constexpr (std::is_same_v<P, AxfCarPaintParams>) return kAxf;
        else if constexpr (std::is_same_v<P, PearlescentParams>) return kPearl;
        else if constexpr (std::is_same_v<P, MerlParams>) return kMerl;
        else {
          static_assert(std::is_same_v<P, CosineLobeParams>, "a paint model without a name");
          return kCosine;
        }
      },
      params);
}

std::vector<int> default_flake_lobes(const std::vector<double>& lobe_roughness) {
  std::vector<int> out;
  if (lobe_roughness.size() <= 1) {
    if (!lobe_roughness.empty()) out.push_back(0);
    return out;
  }
  const auto narrowest = std::min_element(lobe_roughness.begin(), lobe_roughness.end()) - lobe_roughness.begin();
  for (int i = 0; i < static_cast<int>(lobe_roughness.size()); ++i)
    if (i != narrowest) out.push_back(i);
  return out;
}

PaintSpec parse_paint(const ConfigTable& t) {
  PaintSpec s = parse_generic(t, fs::path(t.file()).parent_path(), true);
  s.source = t.file();
  return s;
}

PaintSpec load_paint_file(const fs::path& path) { return parse_paint(ConfigTable::parse_file(path)); }

PaintSpec paint_from_json(const Json& j, const std::string& where, const fs::path& base_dir) {
  if (!j.is_object()) throw DataError(where + ": expected a paint object, got " + std::string(j.type_name()));
  JsonTable t(&j, where, "", false);
  return parse_generic(t, base_dir, false);
}

void check_paint(const PaintSpec& spec) {
  Json j = to_json(spec);
  if (const MerlParams* m = spec.merl()) j["table"] = m->resolved.empty() ? m->table : m->resolved.string();
  JsonTable t(&j, "paint '" + spec.name + "'", "", true);
  parse_generic(t, {}, true);
}

std::string to_toml(const PaintSpec& spec) {
  std::string s;
  s += "name = " + toml_string(spec.name) + "\n";
  s += "model = " + toml_string(spec.model()) + "\n";
  std::string tail;
  if (const auto* p = spec.cook_torrance()) {
    s += "kd = " + rgb_str(p->kd) + "\n";
    for (const auto& l : p->lobes)
      tail += "\n[[lobes]]\nks = " + rgb_str(l.ks) + "\nm = " + num(l.m) + "\nr = " + num(l.r) + "\n";
  } else if (const auto* p = spec.axf_carpaint()) {
    s += "ior = " + num(p->ior) + "\ndiffuse = " + num(p->diffuse) + "\n";
    for (const auto& l : p->lobes)
      tail += "\n[[lobes]]\ncoefficient = " + num(l.coefficient) + "\nspread = " + num(l.spread) +
              "\nf0 = " + num(l.f0) + "\n";
    tail += fmt::format("\n[chi]\ntheta_h_samples = {}\ntheta_i_samples = {}\nscale = {}\nrgb = [\n",
                        p->chi.theta_h_samples, p->chi.theta_i_samples, num(p->chi.scale));
    for (const Rgb& c : p->chi.rgb) tail += "  " + num(c[0]) + ", " + num(c[1]) + ", " + num(c[2]) + ",\n";
    tail += "]\n";
  } else if (const auto* p = spec.pearlescent()) {
    s += "substrate = " + rgb_str(p->substrate) + "\nior = " + num(p->ior) +
         "\ngloss_roughness = " + num(p->gloss_roughness) + "\nabsorption = " + rgb_str(p->absorption) + "\n";
    tail += "\n[pigment]\ncoverage = " + num(p->coverage) + "\nopacity = " + num(p->opacity) +
            "\nroughness = " + num(p->flake_roughness) + "\nfilm_ior = " + num(p->film_ior) +
            "\nfilm_thickness_nm = " + num(p->film_thickness_nm) + "\ncore_ior = " + num(p->core_ior) + "\n";
  } else if (const auto* p = spec.merl()) {
    s += "table = " + toml_string(p->table) + "\n";
  } else if (const auto* p = spec.cosine_lobes()) {
    s += "exponents = [";
    for (std::size_t i = 0; i < p->exponents.size(); ++i) s += (i ? ", " : "") + num(p->exponents[i]);
    s += "]\nkd = " + rgb_str(p->kd) + "\n";
    for (const auto& [key, rows] : {std::pair{"kg", &p->kg}, std::pair{"kdd", &p->kdd}}) {
      s += std::string(key) + " = [\n";
      for (const Rgb& c : *rows) s += "  " + rgb_str(c) + ",\n";
      s += "]\n";
    }
  }
  if (spec.flakes) {
    const FlakeSpec& f = *spec.flakes;
    tail += "\n[flakes]\ndensity = " + num(f.density) + "\nroughness = " + num(f.roughness) +
            "\nlifetime_deg = " + num(f.lifetime_deg) + "\n";
    if (f.coloured())
      tail += "tint_sd = " + num(f.tint_sd) + "\ninterference = " + num(f.interference) +
              "\ninterference_chroma = " + num(f.interference_chroma) +
              "\ninterference_shift_deg = " + num(f.interference_shift_deg) + "\n";
    if (!f.lobes.empty()) {
      tail += "lobes = [";
      for (std::size_t i = 0; i < f.lobes.size(); ++i) tail += (i ? ", " : "") + std::to_string(f.lobes[i] + 1);
      tail += "]\n";
    }
  }
  return s + tail;
}

PaintSpec seen_in_mono(PaintSpec p, const Rgb& w) {
  auto project = [&](Rgb& rgb) { rgb = Rgb::Constant((w * rgb).sum()); };
  if (auto* ct = std::get_if<CookTorranceParams>(&p.params)) {
    project(ct->kd);
    for (CtLobe& l : ct->lobes) project(l.ks);
  } else if (auto* cl = std::get_if<CosineLobeParams>(&p.params)) {
    project(cl->kd);
    for (Rgb& c : cl->kg) project(c);
    for (Rgb& c : cl->kdd) project(c);
  }
  return p;
}

Json to_json(const PaintSpec& spec) {
  Json j;
  j["name"] = spec.name;
  j["model"] = spec.model();
  if (const auto* p = spec.cook_torrance()) {
    j["kd"] = rgb_json(p->kd);
    Json lobes = Json::array();
    for (const auto& l : p->lobes) lobes.push_back({{"ks", rgb_json(l.ks)}, {"m", l.m}, {"r", l.r}});
    j["lobes"] = lobes;
  } else if (const auto* p = spec.axf_carpaint()) {
    j["ior"] = p->ior;
    j["diffuse"] = p->diffuse;
    Json lobes = Json::array();
    for (const auto& l : p->lobes) lobes.push_back({{"coefficient", l.coefficient}, {"spread", l.spread}, {"f0", l.f0}});
    j["lobes"] = lobes;
    Json rgb = Json::array();
    for (const Rgb& c : p->chi.rgb)
      for (int k = 0; k < 3; ++k) rgb.push_back(c[k]);
    j["chi"] = {{"theta_h_samples", p->chi.theta_h_samples},
                {"theta_i_samples", p->chi.theta_i_samples},
                {"scale", p->chi.scale},
                {"rgb", rgb}};
  } else if (const auto* p = spec.pearlescent()) {
    j["substrate"] = rgb_json(p->substrate);
    j["ior"] = p->ior;
    j["gloss_roughness"] = p->gloss_roughness;
    j["absorption"] = rgb_json(p->absorption);
    j["pigment"] = {{"coverage", p->coverage},         {"opacity", p->opacity},
                    {"roughness", p->flake_roughness}, {"film_ior", p->film_ior},
                    {"film_thickness_nm", p->film_thickness_nm}, {"core_ior", p->core_ior}};
  } else if (const auto* p = spec.merl()) {
    j["table"] = p->table;
  } else if (const auto* p = spec.cosine_lobes()) {
    j["exponents"] = p->exponents;
    j["kd"] = rgb_json(p->kd);
    Json kg = Json::array(), kdd = Json::array();
    for (const Rgb& c : p->kg) kg.push_back(rgb_json(c));
    for (const Rgb& c : p->kdd) kdd.push_back(rgb_json(c));
    j["kg"] = kg;
    j["kdd"] = kdd;
  }
  if (spec.flakes) {
    const FlakeSpec& f = *spec.flakes;
    Json fl = {{"density", f.density}, {"roughness", f.roughness}, {"lifetime_deg", f.lifetime_deg}};
    if (f.coloured()) {
      fl["tint_sd"] = f.tint_sd;
      fl["interference"] = f.interference;
      fl["interference_chroma"] = f.interference_chroma;
      fl["interference_shift_deg"] = f.interference_shift_deg;
    }
    if (!f.lobes.empty()) {
      Json lobes = Json::array();
      for (int l : f.lobes) lobes.push_back(l + 1);
      fl["lobes"] = lobes;
    }
    j["flakes"] = fl;
  }
  return j;
}

std::unique_ptr<Brdf> make_brdf(const PaintSpec& spec) {
  if (const auto* p = spec.cook_torrance()) return std::make_unique<CookTorrance>(p->kd, p->lobes);
  if (const auto* p = spec.axf_carpaint()) return std::make_unique<AxfCarPaint>(*p);
  if (const auto* p = spec.pearlescent()) return std::make_unique<LayeredPearlescent>(*p);
  if (const auto* p = spec.cosine_lobes()) return std::make_unique<CosineLobes>(*p);
  const MerlParams& m = *spec.merl();
  return std::make_unique<MerlBrdf>(std::make_shared<const MerlTable>(read_merl(m.resolved)));
}

std::string describe_paint(const PaintSpec& spec) {
  std::string s = fmt::format("paint '{}', model {}\n", spec.name, spec.model());
  auto rgb = [](const Rgb& c) { return fmt::format("[{:.4g}, {:.4g}, {:.4g}]", c[0], c[1], c[2]); };
  if (const auto* p = spec.cook_torrance()) {
    s += fmt::format("  kd (diffuse albedo)   {}\n", rgb(p->kd));
    for (std::size_t i = 0; i < p->lobes.size(); ++i) {
      const auto& l = p->lobes[i];
      s += fmt::format("  lobe {}                ks {}  m {:.4g}  r {:.4g}\n", i + 1, rgb(l.ks), l.m, l.r);
    }
  } else if (const auto* p = spec.axf_carpaint()) {
    s += fmt::format("  clear coat ior        {:.4g}\n  diffuse               {:.4g}\n", p->ior, p->diffuse);
    for (std::size_t i = 0; i < p->lobes.size(); ++i) {
      const auto& l = p->lobes[i];
      s += fmt::format("  lobe {}                coefficient {:.4g}  spread {:.4g}  F0 {:.4g}\n", i + 1,
                       l.coefficient, l.spread, l.f0);
    }
    s += fmt::format("  colour table chi      {} theta_h x {} theta_i samples, scale {:.4g}\n",
                     p->chi.theta_h_samples, p->chi.theta_i_samples, p->chi.scale);
  } else if (const auto* p = spec.pearlescent()) {
    s += fmt::format("  substrate albedo      {}\n  binder ior            {:.4g}\n  gloss roughness       {:.4g}\n"
                     "  absorption (kappa h)  {}\n",
                     rgb(p->substrate), p->ior, p->gloss_roughness, rgb(p->absorption));
    s += fmt::format("  pigment               coverage {:.4g}, opacity {:.4g}, roughness {:.4g}\n", p->coverage,
                     p->opacity, p->flake_roughness);
    s += fmt::format("  interference coating  {:.4g} nm of index {:.4g} on a core of index {:.4g}\n",
                     p->film_thickness_nm, p->film_ior, p->core_ior);
  } else if (const auto* p = spec.merl()) {
    s += fmt::format("  table                 {}\n", p->resolved.string());
  } else if (const auto* p = spec.cosine_lobes()) {
    s += fmt::format("  kd (diffuse albedo)   {}\n", rgb(p->kd));
    // Bounded by every list: describe_paint may be shown a spec that check_paint has not seen.
    const std::size_t n = std::min({p->exponents.size(), p->kg.size(), p->kdd.size()});
    for (std::size_t i = 0; i < n; ++i)
      s += fmt::format("  lobe {:<2}               exponent {:<8.5g} kg {}  kdd {}\n", i + 1, p->exponents[i],
                       rgb(p->kg[i]), rgb(p->kdd[i]));
  }
  if (spec.flakes) {
    const FlakeSpec& f = *spec.flakes;
    std::string carried;
    for (int l : f.lobes) carried += (carried.empty() ? "" : ", ") + std::to_string(l + 1);
    s += fmt::format("  flakes (sparkle)      density {:.4g}, roughness {:.4g}, lifetime {:.4g} deg, carry {}\n",
                     f.density, f.roughness, f.lifetime_deg,
                     carried.empty() ? std::string("the glitter term") : "lobe(s) " + carried);
    if (f.coloured())
      s += fmt::format("  flake colour          tint sd {:.3g}; {:.3g} interference flakes of chroma {:.3g}, hue "
                       "turning {:.3g} deg/deg\n",
                       f.tint_sd, f.interference, f.interference_chroma, f.interference_shift_deg);
  }
  return s;
}

}  // namespace paintlab::brdf
