#include "paintlab/fitting/interpolate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "paintlab/core/error.h"

namespace paintlab::fit {
namespace {

double lerp(double a, double b, double wa, double wb) { return wa * a + wb * b; }

colour::Lab lerp(const colour::Lab& a, const colour::Lab& b, double wa, double wb) {
  return {wa * a.L + wb * b.L, wa * a.a + wb * b.a, wa * a.b + wb * b.b};
}

std::uint64_t lerp_count(std::uint64_t a, std::uint64_t b, double wa, double wb) {
  return static_cast<std::uint64_t>(std::llround(std::max(0.0, wa * static_cast<double>(a) + wb * static_cast<double>(b))));
}

// A count that is a scale, not a measurement (pixels looked at): the parents' counts
// averaged by the weights' magnitudes, so weights (1, 0) give the first's.
std::uint64_t scale_count(std::uint64_t a, std::uint64_t b, double wa, double wb) {
  const double sa = std::abs(wa), sb = std::abs(wb);
  if (!(sa + sb > 0.0)) return 0;
  return static_cast<std::uint64_t>(
      std::llround((sa * static_cast<double>(a) + sb * static_cast<double>(b)) / (sa + sb)));
}

// A value clamped into [lo, hi], with a note when it was outside.
double clamp_noted(double v, double lo, double hi, const std::string& what, std::vector<std::string>* notes) {
  if (v >= lo && v <= hi) return v;
  const double c = std::clamp(std::isfinite(v) ? v : lo, lo, hi);
  notes->push_back(fmt::format("{} {:.6g} -> {:.6g}", what, v, c));
  return c;
}

brdf::Rgb clamp_rgb_noted(const brdf::Rgb& v, const std::string& what, std::vector<std::string>* notes) {
  brdf::Rgb out = v;
  for (int c = 0; c < 3; ++c) out[c] = clamp_noted(v[c], 0.0, INFINITY, fmt::format("{}[{}]", what, c), notes);
  return out;
}

brdf::CookTorranceParams lerp_ct(const brdf::CookTorranceParams& a, const brdf::CookTorranceParams& b, double wa,
                                 double wb, std::vector<std::string>* notes) {
  brdf::CookTorranceParams out;
  out.kd = clamp_rgb_noted(wa * a.kd + wb * b.kd, "cook_torrance kd", notes);
  for (std::size_t l = 0; l < a.lobes.size(); ++l) {
    const std::string w = fmt::format("cook_torrance lobe {}", l + 1);
    brdf::CtLobe lobe;
    lobe.ks = clamp_rgb_noted(wa * a.lobes[l].ks + wb * b.lobes[l].ks, w + " ks", notes);
    lobe.m = clamp_noted(lerp(a.lobes[l].m, b.lobes[l].m, wa, wb), 1e-3, 0.999, w + " m", notes);
    lobe.r = clamp_noted(lerp(a.lobes[l].r, b.lobes[l].r, wa, wb), 1e-6, 0.999999, w + " r", notes);
    out.lobes.push_back(lobe);
  }
  return out;
}

brdf::AxfCarPaintParams lerp_carpaint(const brdf::AxfCarPaintParams& a, const brdf::AxfCarPaintParams& b, double wa,
                                      double wb, std::vector<std::string>* notes) {
  brdf::AxfCarPaintParams out;
  out.ior = clamp_noted(lerp(a.ior, b.ior, wa, wb), 1.0, 3.0, "carpaint ior", notes);
  out.diffuse = clamp_noted(lerp(a.diffuse, b.diffuse, wa, wb), 0.0, INFINITY, "carpaint diffuse", notes);
  for (std::size_t l = 0; l < a.lobes.size(); ++l) {
    const std::string w = fmt::format("carpaint lobe {}", l + 1);
    brdf::AxfLobe lobe;
    lobe.coefficient = clamp_noted(lerp(a.lobes[l].coefficient, b.lobes[l].coefficient, wa, wb), 0.0, INFINITY,
                                   w + " coefficient", notes);
    lobe.spread = clamp_noted(lerp(a.lobes[l].spread, b.lobes[l].spread, wa, wb), 1e-3, 0.999, w + " spread", notes);
    lobe.f0 = clamp_noted(lerp(a.lobes[l].f0, b.lobes[l].f0, wa, wb), 1e-6, 0.999999, w + " f0", notes);
    out.lobes.push_back(lobe);
  }
  // The colour table in CIELAB (Golla and Klein): each entry's colour (times the table's scale)
  // as Lab with white Y = 1, interpolated, and back; the result's scale is 1.
  out.chi = a.chi;
  out.chi.scale = 1.0;
  for (std::size_t k = 0; k < a.chi.rgb.size(); ++k) {
    const colour::Lab la = colour::srgb_to_lab(a.chi.rgb[k] * a.chi.scale);
    const colour::Lab lb = colour::srgb_to_lab(b.chi.rgb[k] * b.chi.scale);
    const brdf::Rgb rgb = colour::xyz_to_srgb(colour::lab_to_xyz(lerp(la, lb, wa, wb), colour::d65()));
    out.chi.rgb[k] = clamp_rgb_noted(rgb, fmt::format("carpaint colour table entry {}", k), notes);
  }
  return out;
}

// Realised clusters: the flows' cuboids at the weights, most likely first. At weights (1, 0)
// or (0, 1) the flows out of (into) one parent cluster coincide and are merged, so a cluster
// split over several flows is whole again.
std::vector<FlakeCluster> realise_clusters(const InterpolatableSlice& s, double wa, double wb, FlakeColourMode mode,
                                           std::uint64_t glints) {
  std::vector<FlakeCluster> out;
  out.reserve(s.clusters.size());
  // Section 4.4 of the paper: the flakes' lightness (L*) and hue (a*, b*) apart. The part kept
  // takes the first paint's values: weights (1, 0).
  const double la = mode == FlakeColourMode::KeepLightness ? 1.0 : wa, lb = mode == FlakeColourMode::KeepLightness ? 0.0 : wb;
  const double ca = mode == FlakeColourMode::LightnessOnly ? 1.0 : wa, cb = mode == FlakeColourMode::LightnessOnly ? 0.0 : wb;
  auto mix = [&](const colour::Lab& x, const colour::Lab& y) {
    return colour::Lab{la * x.L + lb * y.L, ca * x.a + cb * y.a, ca * x.b + cb * y.b};
  };
  const bool only_a = lb == 0.0 && la == 1.0 && cb == 0.0 && ca == 1.0;
  const bool only_b = la == 0.0 && lb == 1.0 && ca == 0.0 && cb == 1.0;
  std::vector<int> merged;  // parent cluster index -> its place in `out`
  for (const InterpolatableCluster& c : s.clusters) {
    if (only_a || only_b) {
      const std::size_t key = only_a ? c.from_index : c.to_index;
      if (key >= merged.size()) merged.resize(key + 1, -1);
      if (merged[key] >= 0) {
        out[static_cast<std::size_t>(merged[key])].probability += c.mass;
        continue;
      }
      merged[key] = static_cast<int>(out.size());
    }
    FlakeCluster r;
    r.mean = mix(c.from.mean, c.to.mean);
    r.lo = mix(c.from.lo, c.to.lo);
    r.hi = mix(c.from.hi, c.to.hi);
    // Extrapolation can turn a cuboid inside out: its corners stay ordered.
    for (double colour::Lab::*f : {&colour::Lab::L, &colour::Lab::a, &colour::Lab::b})
      if (r.lo.*f > r.hi.*f) std::swap(r.lo.*f, r.hi.*f);
    r.probability = c.mass;
    out.push_back(r);
  }
  double total = 0.0;
  for (const FlakeCluster& c : out) total += c.probability;
  for (FlakeCluster& c : out) {
    c.probability /= total;
    c.count = static_cast<std::uint64_t>(std::llround(c.probability * static_cast<double>(glints)));
  }
  std::stable_sort(out.begin(), out.end(), [](const FlakeCluster& x, const FlakeCluster& y) { return x.probability > y.probability; });
  return out;
}

FlakeSlice realise_slice(const InterpolatableSlice& s, double wa, double wb, FlakeColourMode mode, int cdf_steps,
                         std::vector<std::string>* notes) {
  FlakeSlice out;
  out.theta_f = s.theta_f;
  out.theta_i = s.theta_i;
  const std::string w = fmt::format("flake slice ({}, {})", s.theta_f, s.theta_i);
  const double area = clamp_noted(lerp(s.a.area(), s.b.area(), wa, wb), 0.0, 1.0, w + " area", notes);
  out.pixels = scale_count(s.a.pixels, s.b.pixels, wa, wb);
  out.glints = std::min(out.pixels, static_cast<std::uint64_t>(std::llround(area * static_cast<double>(out.pixels))));
  out.intensity_mean = clamp_noted(lerp(s.a.intensity_mean, s.b.intensity_mean, wa, wb), 0.0, INFINITY,
                                   w + " intensity_mean", notes);
  out.glint_model_y = clamp_noted(lerp(s.a.glint_model_y, s.b.glint_model_y, wa, wb), 0.0, INFINITY,
                                  w + " glint_model_y", notes);
  for (std::size_t q = 0; q < out.intensity_quantiles.size(); ++q)
    out.intensity_quantiles[q] = lerp(s.a.intensity_quantiles[q], s.b.intensity_quantiles[q], wa, wb);
  out.runs = lerp_count(s.a.runs, s.b.runs, wa, wb);
  out.lifetime_deg = clamp_noted(lerp(s.a.lifetime_deg, s.b.lifetime_deg, wa, wb), 0.0, 90.0, w + " lifetime_deg", notes);
  if (out.glints > 0 && !s.clusters.empty()) {
    out.clusters = realise_clusters(s, wa, wb, mode, out.glints);
    out.inverse_cdf = flake_inverse_cdf(out.clusters, cdf_steps);
  }
  return out;
}

FlakeStats realise_flakes(const InterpolatablePaint& m, double wa, double wb, FlakeColourMode mode,
                          std::vector<std::string>* notes) {
  const FlakeStats& a = *m.a.flake_stats;
  const FlakeStats& b = *m.b.flake_stats;
  FlakeStats out;
  out.options = a.options;
  out.colour_space = a.colour_space;
  out.mono = a.mono && b.mono;
  out.images = scale_count(a.images, b.images, wa, wb);
  out.step_deg = lerp(a.step_deg, b.step_deg, wa, wb);
  out.lifetime_deg = clamp_noted(lerp(a.lifetime_deg, b.lifetime_deg, wa, wb), 0.0, 90.0, "flake lifetime_deg", notes);
  for (const InterpolatableSlice& s : m.slices) {
    FlakeSlice sl = realise_slice(s, wa, wb, mode, a.options.cdf_steps, notes);
    out.pixels += sl.pixels;
    out.glints += sl.glints;
    out.runs += sl.runs;
    out.slices.push_back(std::move(sl));
  }
  for (std::size_t g = 0; g < a.instrument.size() && g < b.instrument.size(); ++g) {
    const InstrumentSparkle& ia = a.instrument[g];
    const InstrumentSparkle& ib = b.instrument[g];
    InstrumentSparkle is;
    is.illumination_deg = ia.illumination_deg;
    if (ia.measured() && ib.measured()) {  // "not measured" in either stays not measured
      is.pixels = scale_count(ia.pixels, ib.pixels, wa, wb);
      is.area_percent = clamp_noted(lerp(ia.area_percent, ib.area_percent, wa, wb), 0.0, 100.0,
                                    fmt::format("instrument sparkle area at {:g} deg", is.illumination_deg), notes);
      is.glints = static_cast<std::uint64_t>(std::llround(is.area_percent / 100.0 * static_cast<double>(is.pixels)));
      is.intensity = is.glints ? std::max(0.0, lerp(ia.intensity, ib.intensity, wa, wb)) : 0.0;
    }
    out.instrument.push_back(is);
  }
  return out;
}

std::string weight_text(double w) { return fmt::format("{:g}", w); }

}  // namespace

namespace {

// The transports of one slice, read from a transports_to_json object (nullopt: not there).
struct CachedSlices {
  const Json* json = nullptr;
  std::string where;
  std::map<std::pair<int, int>, const Json*> by_bins;
};

// The flows of the slice pair (s, t) from the cache, checked against the clusters.
FlakeTransport cached_transport(const CachedSlices& c, const FlakeSlice& s, const FlakeSlice& t) {
  const std::string w = fmt::format("{}: slice ({}, {})", c.where, s.theta_f, s.theta_i);
  const auto it = c.by_bins.find({s.theta_f, s.theta_i});
  if (it == c.by_bins.end()) throw DataError(w + ": no transports (stored for other paints?)");
  const Json& j = *it->second;
  FlakeTransport tr;
  const double stored = json_get<double>(j, "cost", w);
  std::vector<double> out_a(s.clusters.size(), 0.0), in_b(t.clusters.size(), 0.0);
  const Json& flows = j.at("flows");
  if (!flows.is_array()) throw DataError(w + ": key 'flows': expected an array");
  for (const Json& f : flows) {
    if (!f.is_array() || f.size() != 3) throw DataError(w + ": key 'flows': expected [from, to, mass] entries");
    const auto from = f[0].get<std::size_t>(), to = f[1].get<std::size_t>();
    const double mass = f[2].get<double>();
    if (from >= s.clusters.size() || to >= t.clusters.size() || !(mass >= 0))
      throw DataError(fmt::format("{}: flow [{}, {}, {}] does not fit {} and {} clusters", w, from, to, mass,
                                  s.clusters.size(), t.clusters.size()));
    tr.flows.push_back({from, to, mass});
    out_a[from] += mass;
    in_b[to] += mass;
    const auto& x = s.clusters[from].mean;
    const auto& y = t.clusters[to].mean;
    tr.cost += mass * std::sqrt((x.L - y.L) * (x.L - y.L) + (x.a - y.a) * (x.a - y.a) + (x.b - y.b) * (x.b - y.b));
  }
  for (std::size_t k = 0; k < out_a.size(); ++k)
    if (std::abs(out_a[k] - s.clusters[k].probability) > 1e-6)
      throw DataError(fmt::format("{}: the flows out of cluster {} carry {:.9g}, its probability is {:.9g}", w, k,
                                  out_a[k], s.clusters[k].probability));
  for (std::size_t k = 0; k < in_b.size(); ++k)
    if (std::abs(in_b[k] - t.clusters[k].probability) > 1e-6)
      throw DataError(fmt::format("{}: the flows into cluster {} carry {:.9g}, its probability is {:.9g}", w, k,
                                  in_b[k], t.clusters[k].probability));
  if (std::abs(tr.cost - stored) > 1e-9 * std::max(1.0, std::abs(stored)))
    throw DataError(fmt::format("{}: stored cost {:.12g} is not the flows' cost {:.12g}", w, stored, tr.cost));
  return tr;
}

InterpolatablePaint build_interpolatable(const AxfPaint& a, const AxfPaint& b, const CachedSlices* cache);

}  // namespace

InterpolatablePaint interpolatable_paint(const AxfPaint& a, const AxfPaint& b) { return build_interpolatable(a, b, nullptr); }

InterpolatablePaint interpolatable_paint(const AxfPaint& a, const AxfPaint& b, const Json& transports,
                                         const std::string& where) {
  if (!transports.is_object() || json_get<std::string>(transports, "format", where) != kTransportsFormat)
    throw DataError(where + ": not a " + std::string(kTransportsFormat) + " object");
  if (const int v = json_get<int>(transports, "version", where); v != 1)
    throw DataError(fmt::format("{}: version {} (this paintlab reads 1)", where, v));
  CachedSlices c;
  c.json = &transports;
  c.where = where;
  const Json& slices = transports.at("slices");
  if (!slices.is_array()) throw DataError(where + ": key 'slices': expected an array");
  for (const Json& j : slices) c.by_bins[{json_get<int>(j, "theta_f", where), json_get<int>(j, "theta_i", where)}] = &j;
  return build_interpolatable(a, b, &c);
}

Json transports_to_json(const InterpolatablePaint& m) {
  Json slices = Json::array();
  for (const InterpolatableSlice& s : m.slices) {
    // Every slice (one with colours in one paint only is never read back: nothing was computed).
    Json flows = Json::array();
    for (const auto& c : s.clusters) flows.push_back({c.from_index, c.to_index, c.mass});
    slices.push_back({{"theta_f", s.theta_f}, {"theta_i", s.theta_i}, {"cost", s.transport_cost}, {"flows", flows}});
  }
  return {{"format", kTransportsFormat}, {"version", 1}, {"slices", slices}};
}

namespace {

InterpolatablePaint build_interpolatable(const AxfPaint& a, const AxfPaint& b, const CachedSlices* cache) {
  const std::string pair = fmt::format("'{}' and '{}'", a.name, b.name);
  if (a.colour_space != b.colour_space)
    throw DataError(fmt::format("interpolation of {}: their values are in different colour spaces ({} and {}); "
                                "measure both with a colour calibration",
                                pair, a.colour_space, b.colour_space));
  // A cosine-lobes paint is its basis weights only: it has no parameters that interpolate as
  // Golla and Klein's do (and would need the same exponents); say so rather than "no form in common".
  for (const AxfPaint* x : {&a, &b})
    if (x->model == "cosine-lobes")
      throw DataError(fmt::format("interpolation of {}: '{}' is a cosine-lobes paint; interpolation takes "
                                  "cook-torrance or axf-carpaint forms",
                                  pair, x->name));
  const bool ct = a.cook_torrance && b.cook_torrance, cp = a.carpaint && b.carpaint;
  if (!ct && !cp)
    throw DataError(fmt::format("interpolation of {}: no model form in common ({} and {}); export both as the same "
                                "model",
                                pair, a.model, b.model));
  if ((a.model == "cook-torrance" && !ct) || (a.model == "axf-carpaint" && !cp))
    throw DataError(fmt::format("interpolation of {}: '{}' has no {} form", pair, b.name, a.model));
  if (ct && a.cook_torrance->params.lobes.size() != b.cook_torrance->params.lobes.size())
    throw DataError(fmt::format("interpolation of {}: their Cook-Torrance forms have {} and {} lobes; fit both with "
                                "the same --lobes",
                                pair, a.cook_torrance->params.lobes.size(), b.cook_torrance->params.lobes.size()));
  if (cp) {
    const auto &ca = *a.carpaint, &cb = *b.carpaint;
    if (ca.lobes.size() != cb.lobes.size())
      throw DataError(fmt::format("interpolation of {}: their car-paint forms have {} and {} lobes", pair,
                                  ca.lobes.size(), cb.lobes.size()));
    if (ca.chi.theta_h_samples != cb.chi.theta_h_samples || ca.chi.theta_i_samples != cb.chi.theta_i_samples)
      throw DataError(fmt::format("interpolation of {}: colour tables of {} x {} and {} x {} samples", pair,
                                  ca.chi.theta_h_samples, ca.chi.theta_i_samples, cb.chi.theta_h_samples,
                                  cb.chi.theta_i_samples));
  }
  if (a.flake_stats.has_value() != b.flake_stats.has_value())
    throw DataError(fmt::format("interpolation of {}: '{}' has measured flakes and '{}' none; measure the flakes of "
                                "both (paintlab flakes) or of neither",
                                pair, a.flake_stats ? a.name : b.name, a.flake_stats ? b.name : a.name));
  InterpolatablePaint m;
  m.a = a;
  m.b = b;
  if (!a.flake_stats) return m;
  const FlakeStats& fa = *a.flake_stats;
  const FlakeStats& fb = *b.flake_stats;
  if (fa.options.num_theta_f != fb.options.num_theta_f || fa.options.num_theta_i != fb.options.num_theta_i ||
      fa.options.ior != fb.options.ior)
    throw DataError(fmt::format("interpolation of {}: flake slices of different layouts ({} x {} at ior {:g} and "
                                "{} x {} at ior {:g}); measure both with the same paintlab flakes --slices and --ior",
                                pair, fa.options.num_theta_f, fa.options.num_theta_i, fa.options.ior,
                                fb.options.num_theta_f, fb.options.num_theta_i, fb.options.ior));
  std::map<std::pair<int, int>, const FlakeSlice*> in_b;
  for (const FlakeSlice& s : fb.slices) in_b[{s.theta_f, s.theta_i}] = &s;
  for (const FlakeSlice& s : fa.slices) {
    const auto it = in_b.find({s.theta_f, s.theta_i});
    if (it == in_b.end()) {
      m.notes.push_back(fmt::format("flake slice ({}, {}) measured in '{}' only: left out", s.theta_f, s.theta_i, a.name));
      continue;
    }
    const FlakeSlice& t = *it->second;
    in_b.erase(it);
    InterpolatableSlice is;
    is.theta_f = s.theta_f;
    is.theta_i = s.theta_i;
    is.a = s;
    is.b = t;
    is.a.clusters.clear();
    is.a.inverse_cdf.clear();
    is.b.clusters.clear();
    is.b.inverse_cdf.clear();
    if (!s.clusters.empty() && !t.clusters.empty()) {
      const FlakeTransport tr = cache ? cached_transport(*cache, s, t) : flake_transport(s.clusters, t.clusters);
      is.transport_cost = tr.cost;
      for (const FlakeTransport::Flow& f : tr.flows)
        is.clusters.push_back({s.clusters[f.from], t.clusters[f.to], f.from, f.to, f.mass});
    } else {
      // Colours in one paint only: they stay where they are while the area interpolates.
      const auto& one = s.clusters.empty() ? t.clusters : s.clusters;
      for (std::size_t k = 0; k < one.size(); ++k) is.clusters.push_back({one[k], one[k], k, k, one[k].probability});
    }
    m.slices.push_back(std::move(is));
  }
  for (const auto& [bins, s] : in_b)
    m.notes.push_back(fmt::format("flake slice ({}, {}) measured in '{}' only: left out", bins.first, bins.second, b.name));
  std::sort(m.slices.begin(), m.slices.end(), [](const InterpolatableSlice& x, const InterpolatableSlice& y) {
    return std::make_pair(x.theta_i, x.theta_f) < std::make_pair(y.theta_i, y.theta_f);
  });
  return m;
}

}  // namespace

RealisedPaint realise(const InterpolatablePaint& m, double wa, double wb, bool flake_btf, FlakeColourMode mode) {
  if (!std::isfinite(wa) || !std::isfinite(wb)) throw DataError("interpolation: the weights must be finite numbers");
  RealisedPaint r;
  AxfPaint& p = r.paint;
  p.name = m.a.name;
  p.colour_space = m.a.colour_space;
  p.model = m.a.model;
  if (m.a.cook_torrance && m.b.cook_torrance) {
    AxfCookTorrance ct;
    ct.params = lerp_ct(m.a.cook_torrance->params, m.b.cook_torrance->params, wa, wb, &r.clamped);
    p.cook_torrance = ct;
  }
  if (m.a.carpaint && m.b.carpaint) p.carpaint = lerp_carpaint(*m.a.carpaint, *m.b.carpaint, wa, wb, &r.clamped);
  if (m.a.flake_stats) {
    p.flake_stats = realise_flakes(m, wa, wb, mode, &r.clamped);
    if (flake_btf && !p.flake_stats->empty()) p.flake_btf = make_flake_btf(*p.flake_stats, m.a.flake_btf ? m.a.flake_btf->texture_size : 32);
  }
  p.provenance.source = fmt::format("interpolation: {} {}, {} {}", m.a.name, weight_text(wa), m.b.name, weight_text(wb));
  r.notes = m.notes;
  // The parents' cosine-lobe weights approximate the parents; the colour table interpolates in
  // CIELAB, so their blend would not approximate the result. Left out, and said.
  if (m.a.cosine_lobes || m.b.cosine_lobes)
    r.notes.push_back("the parents' cosine-lobe weights (/cosine_lobes) are left out: they approximate the parents, "
                      "not the interpolated paint");
  return r;
}

RealisedPaint interpolate_paints(const std::vector<AxfPaint>& parents, const std::vector<double>& weights,
                                 const InterpolateOptions& options) {
  if (parents.size() < 2 || parents.size() > 5)
    throw DataError(fmt::format("interpolation: {} paints; give 2 to 5 (each adds up to 49 clusters a slice, and a "
                                "slice holds at most 256)",
                                parents.size()));
  if (weights.size() != parents.size())
    throw DataError(fmt::format("--weights: {} weights for {} paints; give one per paint", weights.size(), parents.size()));
  double sum = 0.0;
  for (double w : weights) {
    if (!std::isfinite(w)) throw DataError("--weights: the weights must be finite numbers");
    sum += w;
  }
  if (!options.free_weights && std::abs(sum - 1.0) > 1e-9)
    throw DataError(fmt::format("--weights: they sum to {:.9g}, not 1 (interpolation and extrapolation keep the sum at 1; "
                                "--free-weights allows any)",
                                sum));
  // Iterated transport, the paints in order of falling weight (so every partial sum of an
  // interpolation is positive): R_2 = (w1 P1 + w2 P2) / s2 as a paint (weights normalised),
  // then R_k = (s_{k-1} R_{k-1} + w_k P_k) / s_k, and the last unnormalised: sum w_i P_i.
  std::vector<std::size_t> order(parents.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  // With a flake colour mode the first paint leads (its flakes' hue or lightness is kept).
  const std::size_t sorted_from = options.flake_colour == FlakeColourMode::All ? 0 : 1;
  std::stable_sort(order.begin() + static_cast<std::ptrdiff_t>(sorted_from), order.end(),
                   [&](std::size_t x, std::size_t y) { return weights[x] > weights[y]; });
  RealisedPaint r;
  AxfPaint current = parents[order[0]];
  double s = weights[order[0]];
  std::string source = "interpolation: ";
  for (std::size_t k = 0; k < parents.size(); ++k)
    source += fmt::format("{}{} {}", k ? ", " : "", parents[k].name, weight_text(weights[k]));
  std::vector<std::string> notes, clamped;
  for (std::size_t k = 1; k < order.size(); ++k) {
    const double next = s + weights[order[k]];
    const bool last = k + 1 == order.size();
    const double scale = last ? 1.0 : next;
    if (!last && std::abs(next) < 1e-12)
      throw DataError(fmt::format("--weights: the {} largest weights sum to 0: no paint to start the transports from "
                                  "(with --free-weights, give weights of a positive sum)",
                                  k + 1));
    const InterpolatablePaint m = k == 1 && options.first_pair ? options.first_pair(current, parents[order[k]])
                                                               : interpolatable_paint(current, parents[order[k]]);
    notes.insert(notes.end(), m.notes.begin(), m.notes.end());
    r = realise(m, s / scale, weights[order[k]] / scale, last, options.flake_colour);
    clamped.insert(clamped.end(), r.clamped.begin(), r.clamped.end());
    current = r.paint;
    current.name = parents[order[0]].name;
    s = next;
  }
  r.clamped = std::move(clamped);
  r.notes = std::move(notes);
  r.paint.provenance.source = source;
  if (!options.name.empty()) {
    r.paint.name = options.name;
  } else {
    std::string n;
    for (std::size_t k = 0; k < parents.size(); ++k)
      n += (k ? "-" : "") + parents[k].name + "-" + fmt::format("{:.0f}", 100.0 * weights[k]);
    std::replace(n.begin(), n.end(), '.', '-');
    r.paint.name = n;
  }
  return r;
}

}  // namespace paintlab::fit
