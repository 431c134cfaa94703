#include "paintlab/fitting/multiangle.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <regex>
#include <stdexcept>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/paint_library.h"
#include "paintlab/fitting/pipeline.h"
#include "paintlab/fitting/session_binning.h"
#include "paintlab/brdf/rusinkiewicz.h"

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
  if (file.extension() == ".toml") {
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

namespace {

// The canonical directions of (theta_h, theta_d, phi_d) (phi_h = 0), phi_d reduced to [0, pi]
// as the MERL layout does.
brdf::DirectionPair canonical(double theta_h, double theta_d, double phi_d) {
  if (phi_d < 0.0) phi_d += kPi;
  if (phi_d > kPi) phi_d -= kPi;
  brdf::HalfDiff hd;
  hd.theta_h = theta_h;
  hd.theta_d = theta_d;
  hd.phi_d = phi_d;
  return brdf::directions_from_half_diff(hd);
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / kPi;
}

}  // namespace


namespace {

// The value at the target from the chosen bins: a weighted local linear fit of f against
// (theta_h, theta_d, sin theta_h phi_d) about the target, so that a lobe's slope across the
// neighbourhood does not bias the estimate (a plain mean would: the neighbours are rarely
// placed symmetrically); the weighted mean where the bins are too few for it. In f, not ln f:
// an instrument reads the arithmetic mean over its aperture, and with sparkle (a few bins
// bright with glints, most not) a fit of ln f would give the geometric mean, far below it. Weights: the bin mean's inverse variance (count / variance), or its count for
// a table without variances. The standard error is the intercept's, scaled by the residual
// scatter where that exceeds the variances (or where there are no variances).
template <class Bin>
MeasuredColour estimate_at(const brdf::MerlTable& table, const std::vector<float>* noise_variance,
                           const std::vector<std::pair<double, const Bin*>>& chosen, const brdf::HalfDiff& target,
                           double radius_deg) {
  MeasuredColour m;
  const std::size_t N = chosen.size();
  bool have_variance = true;
  std::vector<double> w(N);
  std::vector<Eigen::Array3d> v(N), var_mean(N);  // values and their variances (of the bin means)
  std::vector<Eigen::Vector4d> x(N);
  for (std::size_t i = 0; i < N; ++i) {
    const std::size_t b = chosen[i].second->index;
    const double count = std::max<std::uint32_t>(table.count(b), 1);  // a public table: one value per bin
    // The per-sample noise variance the merge carried (a session's) is what the bin's few
    // samples cannot estimate themselves; their own scatter serves from 5 samples on.
    Eigen::Array3d var = Eigen::Array3d::Zero();
    if (noise_variance && noise_variance->size() == 3 * brdf::kMerlBins)
      var = Eigen::Array3d((*noise_variance)[3 * b], (*noise_variance)[3 * b + 1], (*noise_variance)[3 * b + 2])
                .cast<double>();
    else if (table.count(b) >= 5)
      var = table.variance(b);
    have_variance = have_variance && (var > 0.0).all();
    var_mean[i] = var / count;
    // One weight per bin for all three channels, as an instrument averages one aperture for
    // all of them: with per-channel weights a glint (achromatic) would enter each channel's
    // average by another share and come out coloured. The inverse of the bin mean's total
    // variance, or its count.
    w[i] = (var > 0.0).all() ? count / var.sum() : count;
    // A tricube kernel on the distance (LOESS): the nearest bins count most, so that the
    // curvature of a lobe's tail across the neighbourhood biases the estimate less.
    const double u = std::min(chosen[i].first / radius_deg, 1.0);
    const double k = 1.0 - u * u * u;
    w[i] *= std::max(k * k * k, 1e-3);
    v[i] = table.value(b);
    const Eigen::Vector3d c = table.mean_coords(b);
    double dphi = c[2] - (target.phi_d < 0.0 ? target.phi_d + kPi : target.phi_d);
    if (dphi > kPi / 2) dphi -= kPi;
    if (dphi < -kPi / 2) dphi += kPi;
    x[i] = {1.0, c[0] - target.theta_h, c[1] - target.theta_d, std::sin(target.theta_h) * dphi};
  }
  // A slope is fitted only along a coordinate the neighbours span on both sides of the target
  // (by 0.05 deg at least): a light position fixes the angle between light and camera, so a
  // sparse sweep's neighbours may all lie at one theta_d, off the target's; extrapolating along
  // that coordinate would amplify noise without bound. Along such a coordinate the value is
  // the neighbours' (and the radius reported says how far they are).
  constexpr double kSpan = 0.05 * kPi / 180.0;
  std::array<bool, 4> use{true, false, false, false};
  for (int k = 1; k < 4; ++k) {
    double lo = 0.0, hi = 0.0;
    for (const auto& xi : x) {
      lo = std::min(lo, xi[k]);
      hi = std::max(hi, xi[k]);
    }
    use[static_cast<std::size_t>(k)] = lo < -kSpan && hi > kSpan;
  }
  // The estimate is a linear combination sum c_i v_i with the same c_i for every channel: the
  // intercept of the weighted local linear fit, or the weighted mean.
  std::vector<double> coef(N, 0.0);
  auto weighted_mean = [&] {
    double sw = 0.0;
    for (double wi : w) sw += wi;
    for (std::size_t i = 0; i < N; ++i) coef[i] = w[i] / sw;
  };
  constexpr std::size_t kMinForSlope = 8;
  bool local = N >= kMinForSlope;
  std::vector<Eigen::Vector4d> xu(x);  // the coordinates with a slope (the others 0)
  for (auto& xi : xu)
    for (int k = 1; k < 4; ++k)
      if (!use[static_cast<std::size_t>(k)]) xi[k] = 0.0;
  Eigen::LDLT<Eigen::Matrix4d> ldlt;
  if (local) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
    for (std::size_t i = 0; i < N; ++i) A += w[i] * xu[i] * xu[i].transpose();
    for (int k = 1; k < 4; ++k)
      if (!use[static_cast<std::size_t>(k)]) A(k, k) = A(0, 0);  // beta_k = 0
    ldlt.compute(A);
    const Eigen::Vector4d row = ldlt.solve(Eigen::Vector4d::UnitX());  // e0^T A^-1 (A symmetric)
    for (std::size_t i = 0; i < N; ++i) coef[i] = w[i] * row.dot(xu[i]);
    // Interpolation, never extrapolation: an estimate outside the neighbours' values in any
    // channel means the local fit does not describe them (their weighted mean serves instead).
    for (int ch = 0; ch < 3 && local; ++ch) {
      double value = 0.0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (std::size_t i = 0; i < N; ++i) {
        value += coef[i] * v[i][ch];
        lo = std::min(lo, v[i][ch]);
        hi = std::max(hi, v[i][ch]);
      }
      local = value >= lo && value <= hi;
    }
  }
  if (!local) weighted_mean();
  // The standard error: the propagated variances of the bin means, or the residuals' about the
  // fit (the sandwich estimator, HC0) where those are larger (sparkle, a model that does not
  // fit) or where there are no variances.
  for (int ch = 0; ch < 3; ++ch) {
    double value = 0.0;
    for (std::size_t i = 0; i < N; ++i) value += coef[i] * v[i][ch];
    Eigen::Vector4d beta = Eigen::Vector4d::Zero();
    beta[0] = value;
    if (local) {
      Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
      for (std::size_t i = 0; i < N; ++i) rhs += w[i] * v[i][ch] * xu[i];
      beta = ldlt.solve(rhs);
    }
    double var_known = 0.0, var_resid = 0.0;
    for (std::size_t i = 0; i < N; ++i) {
      const double r = v[i][ch] - xu[i].dot(beta);
      var_known += coef[i] * coef[i] * var_mean[i][ch];
      var_resid += coef[i] * coef[i] * r * r;
    }
    m.reflectance[ch] = kPi * value;
    m.reflectance_stderr[ch] = kPi * std::sqrt(have_variance ? std::max(var_known, var_resid) : var_resid);
  }
  return m;
}

}  // namespace

std::vector<std::optional<MeasuredColour>> measured_colour(const brdf::MerlTable& table,
                                                           const std::vector<float>* noise_variance,
                                                           const std::vector<Geometry>& geometries,
                                                           const NearestSamplesOptions& options) {
  if (options.radii_deg.empty()) throw std::invalid_argument("measured_colour: no radii");
  const double r_max = *std::max_element(options.radii_deg.begin(), options.radii_deg.end());
  // The measured bins with their canonical directions, once.
  struct Bin {
    std::size_t index;
    double theta_h, theta_d;
    brdf::DirectionPair dirs;
  };
  std::vector<Bin> bins;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Measured) continue;
    const Eigen::Vector3d c = table.mean_coords(b);
    bins.push_back({b, c[0], c[1], canonical(c[0], c[1], c[2])});
  }
  std::vector<std::optional<MeasuredColour>> out;
  for (const Geometry& g : geometries) {
    const brdf::HalfDiff hd = brdf::half_diff_from_directions(g.towards_light(), g.towards_viewer());
    const brdf::DirectionPair target = canonical(hd.theta_h, hd.theta_d, hd.phi_d);
    // Both directions within r of the target's bound theta_h and theta_d within r.
    const double window = rad(r_max);
    std::vector<std::pair<double, const Bin*>> near;
    for (const Bin& b : bins) {
      if (std::abs(b.theta_h - hd.theta_h) > window || std::abs(b.theta_d - hd.theta_d) > window) continue;
      const double d = std::max(angle_deg(b.dirs.wi, target.wi), angle_deg(b.dirs.wo, target.wo));
      if (d <= r_max) near.push_back({d, &b});
    }
    std::sort(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::optional<MeasuredColour> found;
    for (double r : options.radii_deg) {
      std::uint64_t n = 0;
      std::size_t used = 0;
      while (used < near.size() && near[used].first <= r) n += std::max<std::uint32_t>(table.count(near[used++].second->index), 1);
      if (n < options.min_samples) continue;
      const std::vector<std::pair<double, const Bin*>> chosen(near.begin(), near.begin() + static_cast<long>(used));
      MeasuredColour m = estimate_at(table, noise_variance, chosen, hd, r);
      m.lab = colour::srgb_to_lab(m.reflectance);
      m.n = n;
      m.angular_distance_deg = near[used - 1].first;
      found = m;
      break;
    }
    out.push_back(found);
  }
  return out;
}

std::string uncovered_reason(const brdf::MerlTable& table, const Geometry& g) {
  double lo = 1e9, hi = -1e9;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Measured) continue;
    const double phase = 2.0 * table.mean_coords(b)[1] * 180.0 / kPi;
    lo = std::min(lo, phase);
    hi = std::max(hi, phase);
  }
  const double need = angle_deg(g.towards_light(), g.towards_viewer());
  if (lo > hi) return fmt::format("{}: the data hold no measured bins", g.name);
  if (need < lo - 0.5 || need > hi + 0.5)
    return fmt::format("{} needs {:.0f} deg between light and camera; the data cover {:.0f}..{:.0f} deg", g.name, need,
                       lo, hi);
  return fmt::format("{}: too few samples near it (the sphere's sampling there is sparse, or masked)", g.name);
}

MultiAngleColour measured_paint_colour(const fs::path& data, const std::vector<Geometry>& geometries,
                                       const MeasuredInputOptions& options) {
  SessionBinOptions bin;
  bin.calib_dir = options.calib_dir;
  const FitInput in = load_fit_input(data, bin);
  for (const auto& w : in.warnings) spdlog::warn("{}", w);
  // Sessions say their colour space; a MERL table is read as linear sRGB (what paintlab exports).
  const std::string space = in.input.value("colour_space", std::string(colour::kLinearSrgb));
  if (space != colour::kLinearSrgb)
    throw DataError(fmt::format("{}: the measurement is {}, not {}: CIELAB needs the colour calibration "
                                "(`paintlab calibrate colour`, then measure again)",
                                data.string(), space, colour::kLinearSrgb));
  MultiAngleColour out;
  out.source = data.string();
  out.measured =
      measured_colour(in.table, in.noise_variance.empty() ? nullptr : &in.noise_variance, geometries, options.nearest);
  std::vector<std::string> missing;
  for (std::size_t i = 0; i < geometries.size(); ++i)
    if (!out.measured[i]) missing.push_back(uncovered_reason(in.table, geometries[i]));
  if (!missing.empty())
    throw DataError(fmt::format("{}: no measured samples within {:g} deg of {}; choose a geometry set the sweep "
                                "covers (--geometries)",
                                data.string(), options.nearest.radii_deg.back(), fmt::join(missing, "; ")));
  if (!options.fit_file.empty()) {
    const MultiAngleColour m = paint_colour(options.fit_file, geometries);
    out.paint = m.paint;
    out.model = m.model;
  } else {
    const AxfPaint p = fit_cook_torrance_now(in, options.lobes, data.string());
    out.paint = p.name;
    out.model = colour_at(*brdf::make_brdf(p.paint_spec()), geometries);
  }
  out.flop = flop_index(out.model);
  return out;
}

MultiAngleColour any_colour(const fs::path& input, const std::vector<Geometry>& geometries,
                            const MeasuredInputOptions& options) {
  if (fs::is_directory(input) || input.extension() == ".binary") return measured_paint_colour(input, geometries, options);
  if (!options.fit_file.empty())
    throw UsageError(fmt::format("--fit is for measured data (a session or a .binary table); {} is a paint file",
                                 input.string()));
  return paint_colour(input, geometries);
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

fs::path resolve_paint_input(const std::string& text, const fs::path& library_dir) {
  if (fs::exists(text) || library_dir.empty()) return text;
  const PaintLibrary lib = PaintLibrary::open(library_dir, false);
  return lib.dir() / lib.find(text).file;
}

QcResult quality_control(const fs::path& standard, const fs::path& sample, const std::vector<QcTolerance>& tolerances,
                         const MeasuredInputOptions& measured) {
  std::vector<Geometry> geometries;
  for (const auto& t : tolerances) geometries.push_back(t.geometry);
  // Measured data are fitted and their model compared; the measured values need not cover
  // every geometry for that, so the fit is what both sides give.
  auto model_of = [&](const fs::path& p) {
    if (fs::is_directory(p) || p.extension() == ".binary") {
      MeasuredInputOptions o = measured;
      o.fit_file.clear();  // each side is its own data
      MultiAngleColour c = measured_paint_colour(p, geometries, o);
      c.measured.clear();
      return c;
    }
    return paint_colour(p, geometries);
  };
  return quality_control(model_of(standard), model_of(sample), tolerances);
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

Json colour_against_truth(const brdf::PaintSpec& truth, const MultiAngleColour& c) {
  std::vector<Geometry> geometries;
  for (const auto& a : c.model) geometries.push_back(a.geometry);
  const std::vector<AngleColour> t = colour_at(*brdf::make_brdf(truth), geometries);
  auto lab = [](const colour::Lab& x) { return Json{{"L", x.L}, {"a", x.a}, {"b", x.b}}; };
  Json rows = Json::array();
  double worst_fit = 0.0, worst_measured = 0.0;
  for (std::size_t i = 0; i < geometries.size(); ++i) {
    const double de_fit = colour::delta_e_2000(c.model[i].lab, t[i].lab);
    worst_fit = std::max(worst_fit, de_fit);
    Json r{{"name", geometries[i].name},
           {"truth", lab(t[i].lab)},
           {"fit", lab(c.model[i].lab)},
           {"fit_de00", de_fit},
           {"measured", nullptr},
           {"measured_de00", nullptr}};
    if (i < c.measured.size() && c.measured[i]) {
      const double de_m = colour::delta_e_2000(c.measured[i]->lab, t[i].lab);
      worst_measured = std::max(worst_measured, de_m);
      r["measured"] = lab(c.measured[i]->lab);
      r["measured"]["n"] = c.measured[i]->n;
      r["measured_de00"] = de_m;
    }
    rows.push_back(std::move(r));
  }
  return Json{{"illuminant", "D65"},          {"observer_deg", 2},
              {"geometries", std::move(rows)}, {"worst_fit_de00", worst_fit},
              {"worst_measured_de00", worst_measured}, {"flop_index_truth", flop_index(t) ? Json(*flop_index(t)) : Json()},
              {"flop_index_fit", c.flop ? Json(*c.flop) : Json()}};
}

std::string colour_against_truth_table(const Json& j) {
  std::string s = "five-angle CIELAB (D65, 2 deg observer): the paint, the measurement, the fit; dE00 against the paint\n";
  s += fmt::format("{:<9} {:>21}  {:>21} {:>6}  {:>21} {:>6}\n", "GEOMETRY", "PAINT L* a* b*", "MEASURED", "dE00",
                   "FIT", "dE00");
  auto lab = [](const Json& x) {
    return x.is_null() ? std::string("-")
                       : fmt::format("{:6.2f} {:6.2f} {:6.2f}", x["L"].get<double>(), x["a"].get<double>(),
                                     x["b"].get<double>());
  };
  for (const Json& r : j["geometries"])
    s += fmt::format("{:<9} {:>21}  {:>21} {:>6}  {:>21} {:>6.2f}\n", r["name"].get<std::string>(), lab(r["truth"]),
                     lab(r["measured"]),
                     r["measured_de00"].is_null() ? std::string("-")
                                                  : fmt::format("{:.2f}", r["measured_de00"].get<double>()),
                     lab(r["fit"]), r["fit_de00"].get<double>());
  return s;
}

LibraryMatchResult library_match(const PaintLibrary& library, const MultiAngleColour& target,
                                 const std::vector<Geometry>& geometries) {
  if (target.model.size() != geometries.size())
    throw std::logic_error("library_match: target not evaluated at the geometries");
  LibraryMatchResult out;
  const std::vector<LibraryEntry> entries = library.list();
  out.matches.reserve(entries.size());
  std::vector<const colour::Lab*> labs(geometries.size());
  std::vector<colour::Lab> computed;
  for (const LibraryEntry& e : entries) {
    // The stored colours, by geometry name; all of the set's or none.
    bool stored = !e.colour.empty();
    for (std::size_t i = 0; stored && i < geometries.size(); ++i) {
      labs[i] = nullptr;
      for (const auto& [name, lab] : e.colour)
        if (name == geometries[i].name) labs[i] = &lab;
      stored = labs[i] != nullptr;
    }
    if (stored) {
      ++out.from_index;
    } else {
      const AxfPaint p = library.load(e.name);
      if (p.colour_space != colour::kLinearSrgb) {
        out.skipped.push_back(e.name);
        continue;
      }
      computed.clear();
      for (const AngleColour& c : colour_at(*brdf::make_brdf(p.paint_spec()), geometries)) computed.push_back(c.lab);
      for (std::size_t i = 0; i < geometries.size(); ++i) labs[i] = &computed[i];
      ++out.from_files;
    }
    LibraryMatch m;
    m.name = e.name;
    m.worst_de00 = -1.0;
    double sum = 0.0;
    for (std::size_t i = 0; i < geometries.size(); ++i) {
      const double d = colour::delta_e_2000(target.model[i].lab, *labs[i]);
      sum += d;
      if (d > m.worst_de00) {
        m.worst_de00 = d;
        m.worst_geometry = geometries[i].name;
      }
    }
    m.mean_de00 = sum / static_cast<double>(geometries.size());
    out.matches.push_back(std::move(m));
  }
  std::sort(out.matches.begin(), out.matches.end(), [](const LibraryMatch& a, const LibraryMatch& b) {
    return a.worst_de00 != b.worst_de00 ? a.worst_de00 < b.worst_de00 : a.name < b.name;
  });
  return out;
}

}  // namespace paintlab::fit
