#include "paintlab/fitting/multiangle.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <regex>
#include <stdexcept>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/export.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

namespace {

constexpr double kPi = 3.14159265358979323846;
double rad(double deg) { return deg * kPi / 180.0; }

std::string geometry_name(double illumination_deg, double aspecular_deg) {
  return fmt::format("{:g}as{:g}", illumination_deg, aspecular_deg);
}

// Checks a geometry's angles; `where` names what the user gave.
void check_geometry(const Geometry& g, const std::string& where) {
  if (!(g.illumination_deg >= 0.0 && g.illumination_deg < 90.0))
    throw UsageError(fmt::format("{}: the illumination angle must be in [0, 90) deg from the normal (got {:g})", where,
                                 g.illumination_deg));
  if (!(std::abs(g.viewing_deg()) < 90.0))
    throw UsageError(fmt::format(
        "{}: aspecular {:g} deg from illumination {:g} deg views {:g} deg from the normal, below the surface (the "
        "aspecular angle must lie between {:g} and {:g} deg)",
        where, g.aspecular_deg, g.illumination_deg, std::abs(g.viewing_deg()), g.illumination_deg - 90.0,
        g.illumination_deg + 90.0));
}

std::vector<Geometry> named(double illumination_deg, std::initializer_list<double> aspecular) {
  std::vector<Geometry> out;
  for (double a : aspecular) out.push_back({geometry_name(illumination_deg, a), illumination_deg, a});
  return out;
}

std::vector<Geometry> concat(std::vector<Geometry> a, const std::vector<Geometry>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const AngleColour* find_geometry(const std::vector<AngleColour>& colours, double illumination_deg,
                                 double aspecular_deg) {
  for (const auto& c : colours)
    if (std::abs(c.geometry.illumination_deg - illumination_deg) < 1e-9 &&
        std::abs(c.geometry.aspecular_deg - aspecular_deg) < 1e-9)
      return &c;
  return nullptr;
}

Json lab_json(const colour::Lab& lab, const colour::Rgb& reflectance) {
  return Json{{"L", lab.L},
              {"a", lab.a},
              {"b", lab.b},
              {"C", lab.chroma()},
              {"h", lab.hue_deg()},
              {"R", {reflectance[0], reflectance[1], reflectance[2]}}};
}

}  // namespace

Eigen::Vector3d Geometry::towards_light() const {
  const double t = rad(illumination_deg);
  return {std::sin(t), 0.0, std::cos(t)};
}

Eigen::Vector3d Geometry::towards_viewer() const {
  // The specular direction is at +illumination on the far side (-x); turning it by the
  // aspecular angle towards the light leaves viewing_deg() on that side.
  const double v = rad(viewing_deg());
  return {-std::sin(v), 0.0, std::cos(v)};
}

Geometry parse_geometry(const std::string& text) {
  static const std::regex form(R"(^\s*([0-9]+(?:\.[0-9]+)?)\s*as\s*(-?[0-9]+(?:\.[0-9]+)?)\s*$)");
  std::smatch m;
  if (!std::regex_match(text, m, form))
    throw UsageError(fmt::format("geometry '{}': expected ILLUMINATIONasASPECULAR in degrees, e.g. 45as15 or 45as-15",
                                 text));
  Geometry g;
  g.illumination_deg = std::stod(m[1].str());
  g.aspecular_deg = std::stod(m[2].str());
  g.name = geometry_name(g.illumination_deg, g.aspecular_deg);
  check_geometry(g, fmt::format("geometry '{}'", text));
  return g;
}

const std::vector<std::string>& geometry_set_names() {
  static const std::vector<std::string> names = {"astm-e2194", "five-angle", "six-angle", "e2539"};
  return names;
}

std::vector<Geometry> geometry_set(const std::string& name_or_file) {
  if (name_or_file == "astm-e2194") return named(45, {15, 45, 110});
  if (name_or_file == "five-angle") return named(45, {15, 25, 45, 75, 110});
  if (name_or_file == "six-angle") return named(45, {-15, 15, 25, 45, 75, 110});
  if (name_or_file == "e2539") return concat(named(45, {-15, 15, 25, 45, 75, 110}), named(15, {-15, 15, 25, 45, 80}));
  const fs::path file(name_or_file);
  if (file.extension() != ".toml")
    throw UsageError(fmt::format("geometry set '{}': not a set paintlab knows ({}) nor a .toml file of [[geometry]] "
                                 "tables",
                                 name_or_file, fmt::join(geometry_set_names(), ", ")));
  if (!fs::exists(file)) throw UsageError(fmt::format("geometry set file {} does not exist", file.string()));
  const ConfigTable t = ConfigTable::parse_file(file);
  std::vector<Geometry> out;
  for (const ConfigTable& g : t.tables("geometry", 1, 64)) {
    Geometry x;
    x.illumination_deg = g.number("illumination_deg", Bounds{0.0, 90.0, false, true});
    x.aspecular_deg = g.number("aspecular_deg", Bounds::open(-180.0, 180.0));
    x.name = g.string("name", geometry_name(x.illumination_deg, x.aspecular_deg));
    if (std::abs(x.viewing_deg()) >= 90.0)
      throw ConfigError(file.string(), g.line("aspecular_deg"), g.path("aspecular_deg"),
                        fmt::format("aspecular {:g} deg from illumination {:g} deg views below the surface (it must lie "
                                    "between {:g} and {:g} deg)",
                                    x.aspecular_deg, x.illumination_deg, x.illumination_deg - 90.0,
                                    x.illumination_deg + 90.0));
    for (const auto& y : out)
      if (y.name == x.name)
        throw ConfigError(file.string(), g.line(), g.path("name"), fmt::format("geometry '{}' appears twice", x.name));
    out.push_back(std::move(x));
  }
  t.finish();
  return out;
}

std::vector<AngleColour> colour_at(const brdf::Brdf& paint, const std::vector<Geometry>& geometries) {
  std::vector<AngleColour> out;
  out.reserve(geometries.size());
  for (const auto& g : geometries) {
    AngleColour c;
    c.geometry = g;
    c.reflectance = (kPi * paint.eval(g.towards_light(), g.towards_viewer())).matrix();
    c.lab = colour::srgb_to_lab(c.reflectance);
    out.push_back(std::move(c));
  }
  return out;
}

double flop_index(double L15, double L45, double L110) {
  const double d = L15 - L110;
  return 2.69 * std::copysign(std::pow(std::abs(d), 1.11), d) / std::pow(std::max(L45, 1e-9), 0.86);
}

std::optional<double> flop_index(const std::vector<AngleColour>& colours) {
  const AngleColour* a15 = find_geometry(colours, 45, 15);
  const AngleColour* a45 = find_geometry(colours, 45, 45);
  const AngleColour* a110 = find_geometry(colours, 45, 110);
  if (!a15 || !a45 || !a110) return std::nullopt;
  return flop_index(a15->lab.L, a45->lab.L, a110->lab.L);
}

MultiAngleColour paint_colour(const fs::path& file, const std::vector<Geometry>& geometries) {
  MultiAngleColour out;
  out.source = file.string();
  std::unique_ptr<brdf::Brdf> model;
  if (file.extension() == ".binary") {
    // A MERL table: read as linear sRGB, which is what paintlab writes (an export of a
    // colour-calibrated session); the table itself is what the model evaluates.
    if (!fs::is_regular_file(file)) throw IoError(file.string(), "no such file");
    brdf::PaintSpec spec;
    spec.name = file.stem().string();
    spec.params = brdf::MerlParams{file.string(), file};
    out.paint = spec.name;
    model = brdf::make_brdf(spec);
  } else if (file.extension() == ".toml") {
    // Paint files are linear sRGB by convention (docs/paint-files.md); every model has a colour.
    const brdf::PaintSpec spec = brdf::load_paint_file(file);
    out.paint = spec.name;
    model = brdf::make_brdf(spec);
  } else {
    const AxfPaint paint = load_any_paint(file);
    if (paint.colour_space != colour::kLinearSrgb)
      throw DataError(fmt::format(
          "{}: the paint's values are {}, not {}: CIELAB needs the colour calibration (`paintlab calibrate colour`, "
          "then measure and fit again)",
          file.string(), paint.colour_space, colour::kLinearSrgb));
    out.paint = paint.name;
    model = brdf::make_brdf(paint.paint_spec());
  }
  out.model = colour_at(*model, geometries);
  out.flop = flop_index(out.model);
  return out;
}

Json colour_json(const MultiAngleColour& c) {
  Json geometries = Json::array();
  for (std::size_t i = 0; i < c.model.size(); ++i) {
    const AngleColour& m = c.model[i];
    Json g{{"name", m.geometry.name},
           {"illumination_deg", m.geometry.illumination_deg},
           {"aspecular_deg", m.geometry.aspecular_deg},
           {"viewing_deg", m.geometry.viewing_deg()},
           {"model", lab_json(m.lab, m.reflectance)},
           {"measured", nullptr},
           {"de00", nullptr}};
    if (i < c.measured.size() && c.measured[i]) {
      const MeasuredColour& s = *c.measured[i];
      Json j = lab_json(s.lab, s.reflectance);
      j["n"] = s.n;
      j["R_stderr"] = {s.reflectance_stderr[0], s.reflectance_stderr[1], s.reflectance_stderr[2]};
      j["angular_distance_deg"] = s.angular_distance_deg;
      g["measured"] = std::move(j);
      g["de00"] = colour::delta_e_2000(m.lab, s.lab);
    }
    geometries.push_back(std::move(g));
  }
  Json out{{"paint", c.paint},
           {"source", c.source},
           {"illuminant", "D65"},
           {"observer_deg", 2},
           {"colour_space", colour::kLinearSrgb},
           {"geometries", std::move(geometries)},
           {"flop_index", nullptr}};
  if (c.flop) out["flop_index"] = *c.flop;
  return out;
}

std::string colour_table(const MultiAngleColour& c) {
  std::string s = fmt::format("{} ({}): CIELAB, D65, 2 deg observer; R = pi f in linear sRGB\n", c.paint, c.source);
  const bool measured = std::any_of(c.measured.begin(), c.measured.end(), [](const auto& m) { return m.has_value(); });
  s += fmt::format("{:<9} {:>6} {:>7} {:>7} {:>6} {:>6} {:>6}   {:<22}", "GEOMETRY", "VIEW", "L*", "a*", "b*", "C*", "h",
                   "R (r, g, b)");
  if (measured) s += fmt::format("  {:>7} {:>7} {:>7} {:>6} {:>6}", "L* meas", "a* meas", "b* meas", "n", "dE00");
  s += "\n";
  for (std::size_t i = 0; i < c.model.size(); ++i) {
    const AngleColour& m = c.model[i];
    s += fmt::format("{:<9} {:>6.1f} {:>7.2f} {:>7.2f} {:>6.2f} {:>6.2f} {:>6.1f}   {:.4f}, {:.4f}, {:.4f}",
                     m.geometry.name, m.geometry.viewing_deg(), m.lab.L, m.lab.a, m.lab.b, m.lab.chroma(),
                     m.lab.hue_deg(), m.reflectance[0], m.reflectance[1], m.reflectance[2]);
    if (measured) {
      if (i < c.measured.size() && c.measured[i]) {
        const MeasuredColour& x = *c.measured[i];
        s += fmt::format("  {:>7.2f} {:>7.2f} {:>7.2f} {:>6} {:>6.2f}", x.lab.L, x.lab.a, x.lab.b, x.n,
                         colour::delta_e_2000(m.lab, x.lab));
      } else {
        s += fmt::format("  {:>7} {:>7} {:>7} {:>6} {:>6}", "-", "-", "-", "0", "-");
      }
    }
    s += "\n";
  }
  if (c.flop)
    s += fmt::format("flop index {:.2f} (2.69 (L*15 - L*110)^1.11 / L*45^0.86)\n", *c.flop);
  else
    s += "flop index: needs 45as15, 45as45 and 45as110\n";
  s += "VIEW: viewing angle from the normal, negative on the light's side.\n";
  return s;
}

std::vector<QcTolerance> default_tolerances(const std::string& set) {
  std::vector<QcTolerance> out;
  for (const Geometry& g : geometry_set(set)) {
    QcTolerance t;
    t.geometry = g;
    t.de00 = 1.0;
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<QcTolerance> load_tolerances(const fs::path& file) {
  if (!fs::exists(file)) throw UsageError(fmt::format("tolerance file {} does not exist", file.string()));
  const ConfigTable t = ConfigTable::parse_file(file);
  std::vector<QcTolerance> out;
  for (const ConfigTable& x : t.tables("tolerance", 1, 64)) {
    QcTolerance q;
    const std::string text = x.string("geometry");
    try {
      q.geometry = parse_geometry(text);
    } catch (const UsageError& e) {
      throw ConfigError(file.string(), x.line("geometry"), x.path("geometry"), e.what());
    }
    q.de00 = x.maybe_number("de00", Bounds::positive());
    q.dL = x.maybe_number("dL", Bounds::positive());
    q.dC = x.maybe_number("dC", Bounds::positive());
    q.dH = x.maybe_number("dH", Bounds::positive());
    q.kL = x.number("kL", 1.0, Bounds::positive());
    q.kC = x.number("kC", 1.0, Bounds::positive());
    q.kH = x.number("kH", 1.0, Bounds::positive());
    if (!q.de00 && !q.dL && !q.dC && !q.dH)
      throw ConfigError(file.string(), x.line(), x.path("geometry"),
                        fmt::format("tolerance at {} sets no limit: give de00, dL, dC or dH", q.geometry.name));
    for (const auto& y : out)
      if (y.geometry.name == q.geometry.name)
        throw ConfigError(file.string(), x.line("geometry"), x.path("geometry"),
                          fmt::format("a second tolerance for {}", q.geometry.name));
    out.push_back(std::move(q));
  }
  if (const auto set = t.maybe_string("geometries")) {
    std::vector<Geometry> geometries;
    try {
      geometries = geometry_set(*set);
    } catch (const Error& e) {
      throw ConfigError(file.string(), t.line("geometries"), "geometries", e.what());
    }
    std::vector<QcTolerance> ordered;
    for (const Geometry& g : geometries) {
      const auto it = std::find_if(out.begin(), out.end(), [&](const QcTolerance& q) {
        return q.geometry.illumination_deg == g.illumination_deg && q.geometry.aspecular_deg == g.aspecular_deg;
      });
      if (it == out.end())
        throw ConfigError(file.string(), t.line("geometries"), "geometries",
                          fmt::format("geometry {} of set '{}' has no [[tolerance]]", g.name, *set));
      ordered.push_back(*it);
    }
    if (ordered.size() != out.size()) {
      for (const auto& q : out)
        if (std::none_of(geometries.begin(), geometries.end(), [&](const Geometry& g) { return g.name == q.geometry.name; }))
          throw ConfigError(file.string(), t.line("geometries"), "geometries",
                            fmt::format("the tolerance for {} is not a geometry of set '{}'", q.geometry.name, *set));
    }
    out = std::move(ordered);
  }
  t.finish();
  return out;
}

QcResult quality_control(const MultiAngleColour& standard, const MultiAngleColour& sample,
                         const std::vector<QcTolerance>& tolerances) {
  if (standard.model.size() != tolerances.size() || sample.model.size() != tolerances.size())
    throw std::logic_error("quality_control: colours not evaluated at the tolerances' geometries");
  QcResult r;
  r.standard = standard.paint;
  r.sample = sample.paint;
  for (std::size_t i = 0; i < tolerances.size(); ++i) {
    QcAngle a;
    a.tolerance = tolerances[i];
    a.standard = standard.model[i].lab;
    a.sample = sample.model[i].lab;
    const double c1 = a.standard.chroma(), c2 = a.sample.chroma();
    a.dL = a.sample.L - a.standard.L;
    a.dC = c2 - c1;
    // The metric hue difference: 2 sqrt(C1 C2) sin(dh / 2), dh the hue angle difference.
    double dh = a.sample.hue_deg() - a.standard.hue_deg();
    if (dh > 180.0) dh -= 360.0;
    if (dh < -180.0) dh += 360.0;
    a.dH = 2.0 * std::sqrt(c1 * c2) * std::sin(rad(dh) / 2.0);
    a.de00 = colour::delta_e_2000(a.standard, a.sample, a.tolerance.kL, a.tolerance.kC, a.tolerance.kH);
    std::vector<std::string> why;
    const QcTolerance& t = a.tolerance;
    if (t.de00 && a.de00 > *t.de00) why.push_back(fmt::format("dE00 {:.2f} > {:.2f}", a.de00, *t.de00));
    if (t.dL && std::abs(a.dL) > *t.dL) why.push_back(fmt::format("dL* {:+.2f} beyond {:.2f}", a.dL, *t.dL));
    if (t.dC && std::abs(a.dC) > *t.dC) why.push_back(fmt::format("dC* {:+.2f} beyond {:.2f}", a.dC, *t.dC));
    if (t.dH && std::abs(a.dH) > *t.dH) why.push_back(fmt::format("dH* {:+.2f} beyond {:.2f}", a.dH, *t.dH));
    a.pass = why.empty();
    a.failed = fmt::format("{}", fmt::join(why, "; "));
    r.pass = r.pass && a.pass;
    r.angles.push_back(std::move(a));
  }
  return r;
}

QcResult quality_control(const fs::path& standard, const fs::path& sample, const std::vector<QcTolerance>& tolerances) {
  std::vector<Geometry> geometries;
  for (const auto& t : tolerances) geometries.push_back(t.geometry);
  return quality_control(paint_colour(standard, geometries), paint_colour(sample, geometries), tolerances);
}

Json qc_json(const QcResult& r) {
  Json angles = Json::array();
  auto limit = [](const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); };
  for (const auto& a : r.angles) {
    const QcTolerance& t = a.tolerance;
    angles.push_back({{"name", t.geometry.name},
                      {"illumination_deg", t.geometry.illumination_deg},
                      {"aspecular_deg", t.geometry.aspecular_deg},
                      {"standard", {{"L", a.standard.L}, {"a", a.standard.a}, {"b", a.standard.b}}},
                      {"sample", {{"L", a.sample.L}, {"a", a.sample.a}, {"b", a.sample.b}}},
                      {"dL", a.dL},
                      {"dC", a.dC},
                      {"dH", a.dH},
                      {"de00", a.de00},
                      {"tolerance",
                       {{"de00", limit(t.de00)},
                        {"dL", limit(t.dL)},
                        {"dC", limit(t.dC)},
                        {"dH", limit(t.dH)},
                        {"kL", t.kL},
                        {"kC", t.kC},
                        {"kH", t.kH}}},
                      {"pass", a.pass},
                      {"failed", a.failed}});
  }
  return Json{{"standard", r.standard}, {"sample", r.sample}, {"illuminant", "D65"}, {"observer_deg", 2},
              {"geometries", std::move(angles)}, {"pass", r.pass}};
}

std::string qc_table(const QcResult& r) {
  std::string s = fmt::format("sample {} against standard {} (CIELAB, D65, 2 deg observer; sample - standard)\n",
                              r.sample, r.standard);
  s += fmt::format("{:<9} {:>7} {:>7} {:>7} {:>7}  {:<6} {}\n", "GEOMETRY", "dL*", "dC*", "dH*", "dE00", "RESULT",
                   "WHY");
  for (const auto& a : r.angles)
    s += fmt::format("{:<9} {:>+7.2f} {:>+7.2f} {:>+7.2f} {:>7.2f}  {:<6} {}\n", a.tolerance.geometry.name, a.dL, a.dC,
                     a.dH, a.de00, a.pass ? "pass" : "FAIL", a.failed);
  const auto failed = std::count_if(r.angles.begin(), r.angles.end(), [](const QcAngle& a) { return !a.pass; });
  s += r.pass ? fmt::format("PASS: all {} geometries within tolerance\n", r.angles.size())
              : fmt::format("FAIL: {} of {} geometries out of tolerance\n", failed, r.angles.size());
  return s;
}

}  // namespace paintlab::fit
