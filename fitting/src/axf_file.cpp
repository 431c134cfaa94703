#include "paintlab/fitting/axf_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <set>

#include "axf_file_h5.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

namespace {

using h5::DoubleArray;
using h5::Handle;
using h5::Problems;
using h5::Writer;

// The conventions of format version 1 (and "cosine_lobes", version 5), written into
// /conventions and checked word for word by the validator (docs/axf-like.md explains each).
const std::vector<std::pair<std::string, std::string>> kConventions = {
    {"brdf_unit", "1/sr"},
    {"frame", "local shading frame, normal n = +z; i points to the light, o to the camera; angles in radians"},
    {"values", "linear camera RGB: no gamma, no sRGB transfer curve, no tone mapping"},
    {"beckmann_d",
     "D(m, theta_h) = exp(-tan^2(theta_h) / m^2) / (m^2 cos^4(theta_h)), WITHOUT the 1/pi of the normalised "
     "Beckmann distribution"},
    {"specular_lobe",
     "lobe = coefficient * F(F0, h.o) * D(spread, theta_h) * G / (pi (n.i)(n.o)); the pi of this denominator is "
     "the 1/pi that D lacks"},
    {"fresnel", "lobes: Schlick F(F0, c) = F0 + (1 - F0)(1 - c)^5 with c = h.o"},
    {"geometry", "G = min(1, 2 (n.h)(n.o) / (o.h), 2 (n.h)(n.i) / (o.h))"},
    {"diffuse",
     "carpaint: diffuse / pi (a scalar albedo), multiplied by the colour table like the lobes; cook_torrance: "
     "kd / pi (RGB albedo)"},
    {"carpaint",
     "f = (1 - F_ior(n.i)) (1 - F_ior(n.o)) chi(theta_hbar, theta_ibar) (diffuse / pi + sum_k lobe_k) with the "
     "lobes and diffuse evaluated at i and o refracted into the clear coat (Snell, index ior, same azimuth); "
     "F_ior is the exact unpolarised dielectric Fresnel reflectance; no 1/ior^2 factor; the clear coat's mirror "
     "reflection F_ior(n.i) is not included (a renderer adds it)"},
    {"colour_table_indexing",
     "colour_table[a][b] is chi at u = (a + 0.5) / Nh, v = (b + 0.5) / Ni with u = 2 theta_hbar / pi, "
     "v = 2 theta_ibar / pi, theta_hbar = angle(n, hbar), theta_ibar = angle(hbar, ibar) of the refracted "
     "directions; bilinear lookup clamped at the borders, times colour_table_scale"},
    {"colour_table_domain",
     "full: every sample of [0, pi/2] x [0, pi/2] holds data, also where theta_ibar > pi/2 - theta_hbar "
     "(X-Rite files fill only theta_ibar <= pi/2 - theta_hbar)"},
    {"cook_torrance",
     "f = kd / pi + sum_l ks_l F(r_l, h.o) D(m_l, theta_h) G / (pi (n.i)(n.o)) in air (Guenther et al. 2005, "
     "eq. 1); lobes broadest first as fitted; *_std are one standard deviation"},
    // Version 5. The kg terms carry no (n.i) in f (n.i): the source's gloss lobes, a trap for a
    // reader who expects every term of a BRDF to be multiplied by the cosine.
    {"cosine_lobes",
     "f(i, o) (n.i) = kd / pi (n.i) + sum_k kg_k (r.o)^E_k + (n.i) sum_k kdd_k (r.o)^E_k with r = 2 (n.i) n - i "
     "the mirror direction of the light, (r.o) clamped at 0 and E_k = exponents[k] (increasing): the BRDF is "
     "kd / pi + sum_k (kg_k / (n.i) + kdd_k) (r.o)^E_k in air; kd is an albedo, kg and kdd are in 1/sr"},
};

// The format version from which a convention is required (older files lack it).
int convention_since(const std::string& name) { return name == "cosine_lobes" ? 5 : 1; }

constexpr double kHalfPi = std::numbers::pi / 2;

bool valid_name(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
}

bool valid_sha256(const std::string& s) {
  return s.size() == 64 &&
         std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

std::vector<double> theta_samples(int n) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (int a = 0; a < n; ++a) v[static_cast<std::size_t>(a)] = (a + 0.5) / n * kHalfPi;
  return v;
}

std::vector<double> rgb_vec(const brdf::Rgb& c) { return {c[0], c[1], c[2]}; }

// ---- writing ----

// The name of the attribute holding the SHA-256 of a paint's content (format version 2).
constexpr const char* kContentSha256 = "content_sha256";

void write_paint(hid_t root, const std::string& rp, const AxfPaint& paint, const Writer& file_writer) {
  h5::Digest digest(rp);
  const Writer w = file_writer.with_digest(&digest);
  w.attr_string(root, "format", kAxfFormat, rp);
  w.attr_int(root, "format_version", kAxfFormatVersion, rp);
  w.attr_string(root, "paint_name", paint.name, rp);
  w.attr_string(root, "model", paint.model, rp);

  {
    const std::string gp = h5::join(rp, "conventions");
    Handle g = w.create_group(root, "conventions", gp);
    for (const auto& [k, v] : kConventions)
      w.attr_string(g.get(), k, k == "values" ? axf_values_convention(paint.colour_space) : v, gp);
  }

  if (paint.carpaint) {
    const auto& c = *paint.carpaint;
    const std::string gp = h5::join(rp, "carpaint");
    Handle g = w.create_group(root, "carpaint", gp);
    const auto n = static_cast<hsize_t>(c.lobes.size());
    w.attr_int(g.get(), "lobe_count", static_cast<std::int64_t>(n), gp);
    w.scalar(g.get(), "ior", c.ior, h5::join(gp, "ior"));
    w.scalar(g.get(), "diffuse", c.diffuse, h5::join(gp, "diffuse"));
    std::vector<double> coeffs, spreads, f0s;
    for (const auto& l : c.lobes) {
      coeffs.push_back(l.coefficient);
      spreads.push_back(l.spread);
      f0s.push_back(l.f0);
    }
    w.doubles(g.get(), "ct_coeffs", coeffs, {n}, h5::join(gp, "ct_coeffs"));
    w.doubles(g.get(), "ct_spreads", spreads, {n}, h5::join(gp, "ct_spreads"));
    w.doubles(g.get(), "ct_f0s", f0s, {n}, h5::join(gp, "ct_f0s"));
    const auto nh = static_cast<hsize_t>(c.chi.theta_h_samples), ni = static_cast<hsize_t>(c.chi.theta_i_samples);
    std::vector<double> table;
    table.reserve(c.chi.rgb.size() * 3);
    for (const auto& v : c.chi.rgb) table.insert(table.end(), {v[0], v[1], v[2]});
    const std::string tp = h5::join(gp, "colour_table");
    w.doubles(g.get(), "colour_table", table, {nh, ni, 3}, tp);
    w.scalar(g.get(), "colour_table_scale", c.chi.scale, h5::join(gp, "colour_table_scale"));
    w.doubles(g.get(), "colour_table_theta_h_rad", theta_samples(c.chi.theta_h_samples), {nh},
              h5::join(gp, "colour_table_theta_h_rad"));
    w.doubles(g.get(), "colour_table_theta_i_rad", theta_samples(c.chi.theta_i_samples), {ni},
              h5::join(gp, "colour_table_theta_i_rad"));
    if (paint.carpaint_stddev) {
      const auto& sd = *paint.carpaint_stddev;
      w.scalar(g.get(), "ior_std", sd.ior, h5::join(gp, "ior_std"));
      w.scalar(g.get(), "diffuse_std", sd.diffuse, h5::join(gp, "diffuse_std"));
      std::vector<double> cs, ss, fs;
      for (const auto& l : sd.lobes) {
        cs.push_back(l.coefficient);
        ss.push_back(l.spread);
        fs.push_back(l.f0);
      }
      const auto ns = static_cast<hsize_t>(sd.lobes.size());
      w.doubles(g.get(), "ct_coeffs_std", cs, {ns}, h5::join(gp, "ct_coeffs_std"));
      w.doubles(g.get(), "ct_spreads_std", ss, {ns}, h5::join(gp, "ct_spreads_std"));
      w.doubles(g.get(), "ct_f0s_std", fs, {ns}, h5::join(gp, "ct_f0s_std"));
    }
  }

  if (paint.cook_torrance) {
    const auto& ct = *paint.cook_torrance;
    const std::string gp = h5::join(rp, "cook_torrance");
    Handle g = w.create_group(root, "cook_torrance", gp);
    const auto n = static_cast<hsize_t>(ct.params.lobes.size());
    w.attr_int(g.get(), "lobe_count", static_cast<std::int64_t>(n), gp);
    auto put = [&](const std::string& suffix, const brdf::Rgb& kd, const std::vector<brdf::CtLobe>& lobes) {
      std::vector<double> ks, m, r;
      for (const auto& l : lobes) {
        ks.insert(ks.end(), {l.ks[0], l.ks[1], l.ks[2]});
        m.push_back(l.m);
        r.push_back(l.r);
      }
      w.doubles(g.get(), "kd" + suffix, rgb_vec(kd), {3}, h5::join(gp, "kd" + suffix));
      w.doubles(g.get(), "ks" + suffix, ks, {static_cast<hsize_t>(lobes.size()), 3}, h5::join(gp, "ks" + suffix));
      w.doubles(g.get(), "m" + suffix, m, {static_cast<hsize_t>(lobes.size())}, h5::join(gp, "m" + suffix));
      w.doubles(g.get(), "r" + suffix, r, {static_cast<hsize_t>(lobes.size())}, h5::join(gp, "r" + suffix));
    };
    put("", ct.params.kd, ct.params.lobes);
    if (ct.stddev) put("_std", ct.stddev->kd, ct.stddev->lobes);
  }

  if (paint.cosine_lobes) {  // format version 5
    const auto& cl = *paint.cosine_lobes;
    const std::string gp = h5::join(rp, "cosine_lobes");
    Handle g = w.create_group(root, "cosine_lobes", gp);
    const auto n = static_cast<hsize_t>(cl.exponents.size());
    w.attr_int(g.get(), "lobe_count", static_cast<std::int64_t>(n), gp);
    w.doubles(g.get(), "exponents", cl.exponents, {n}, h5::join(gp, "exponents"));
    w.doubles(g.get(), "kd", rgb_vec(cl.kd), {3}, h5::join(gp, "kd"));
    auto rows = [](const std::vector<brdf::Rgb>& v) {
      std::vector<double> out;
      for (const auto& c : v) out.insert(out.end(), {c[0], c[1], c[2]});
      return out;
    };
    w.doubles(g.get(), "kg", rows(cl.kg), {static_cast<hsize_t>(cl.kg.size()), 3}, h5::join(gp, "kg"));
    w.doubles(g.get(), "kdd", rows(cl.kdd), {static_cast<hsize_t>(cl.kdd.size()), 3}, h5::join(gp, "kdd"));
  }

  if (paint.flakes) {
    const auto& f = *paint.flakes;
    const std::string gp = h5::join(rp, "flakes");
    Handle g = w.create_group(root, "flakes", gp);
    w.scalar(g.get(), "density", f.density, h5::join(gp, "density"));
    w.scalar(g.get(), "roughness", f.roughness, h5::join(gp, "roughness"));
    w.scalar(g.get(), "lifetime_deg", f.lifetime_deg, h5::join(gp, "lifetime_deg"));
    std::vector<std::int64_t> lobes;
    for (int l : f.lobes) lobes.push_back(l + 1);
    w.ints(g.get(), "lobes", lobes, {static_cast<hsize_t>(lobes.size())}, h5::join(gp, "lobes"));
    if (f.coloured()) {  // format version 4
      w.scalar(g.get(), "tint_sd", f.tint_sd, h5::join(gp, "tint_sd"));
      w.scalar(g.get(), "interference", f.interference, h5::join(gp, "interference"));
      w.scalar(g.get(), "interference_chroma", f.interference_chroma, h5::join(gp, "interference_chroma"));
      w.scalar(g.get(), "interference_shift_deg", f.interference_shift_deg, h5::join(gp, "interference_shift_deg"));
    }
  }

  if (paint.flake_stats) {  // format version 4: the measured flakes (flakes.json, docs/sparkle.md)
    const std::string gp = h5::join(rp, "flake_stats");
    Handle g = w.create_group(root, "flake_stats", gp);
    w.strings(g.get(), "json", {flakes_to_json(*paint.flake_stats).dump()}, h5::join(gp, "json"));
  }
  if (paint.flake_btf) {  // format version 4: the CPA2-style flake BTF
    const FlakeBtf& b = *paint.flake_btf;
    const std::string gp = h5::join(rp, "flake_btf");
    Handle g = w.create_group(root, "flake_btf", gp);
    w.attr_string(g.get(), "bin_convention", kFlakeBinConvention, gp);
    w.scalar_int(g.get(), "num_thetaF", b.num_theta_f, h5::join(gp, "num_thetaF"));
    w.scalar_int(g.get(), "num_thetaI", b.num_theta_i, h5::join(gp, "num_thetaI"));
    w.scalar_int(g.get(), "max_thetaI", b.max_theta_i, h5::join(gp, "max_thetaI"));
    w.scalar_int(g.get(), "texture_size", b.texture_size, h5::join(gp, "texture_size"));
    w.scalar(g.get(), "ior", b.ior, h5::join(gp, "ior"));
    const std::vector<std::int64_t> lut(b.slice_lut.begin(), b.slice_lut.end());
    w.ints(g.get(), "thetaFI_sliceLUT", lut, {static_cast<hsize_t>(lut.size())}, h5::join(gp, "thetaFI_sliceLUT"));
    const auto n = static_cast<hsize_t>(b.slices()), t = static_cast<hsize_t>(b.texture_size);
    w.doubles(g.get(), "BTFflakes", b.texels, {n, t, t, 3}, h5::join(gp, "BTFflakes"));
    w.doubles(g.get(), "slice_mean", b.slice_mean, {n, 3}, h5::join(gp, "slice_mean"));
  }

  if (paint.fit_quality) {
    const auto& q = *paint.fit_quality;
    const std::string gp = h5::join(rp, "fit_quality");
    Handle g = w.create_group(root, "fit_quality", gp);
    w.scalar(g.get(), "log_rms", q.log_rms, h5::join(gp, "log_rms"));
    w.scalar_int(g.get(), "bins_used", q.bins_used, h5::join(gp, "bins_used"));
    w.attr_int(g.get(), "converged", q.converged ? 1 : 0, gp);
    w.attr_string(g.get(), "residual_json", q.residual.dump(), gp);
  }

  {
    const auto& pv = paint.provenance;
    const std::string gp = h5::join(rp, "provenance");
    Handle g = w.create_group(root, "provenance", gp);
    w.attr_string(g.get(), "sample_name", pv.sample_name, gp);
    w.attr_string(g.get(), "measured_utc", pv.measured_utc, gp);
    w.attr_string(g.get(), "exported_utc", pv.exported_utc, gp);
    w.attr_string(g.get(), "rig_name", pv.rig_name, gp);
    w.attr_string(g.get(), "session_sha256", pv.session_sha256, gp);
    w.attr_string(g.get(), "software_version", pv.software_version, gp);
    w.attr_string(g.get(), "source", pv.source, gp);
    std::vector<std::string> files, sums;
    for (const auto& [f, s] : pv.calibration_sha256) {
      files.push_back(f);
      sums.push_back(s);
    }
    w.strings(g.get(), "calibration_files", files, h5::join(gp, "calibration_files"));
    w.strings(g.get(), "calibration_sha256", sums, h5::join(gp, "calibration_sha256"));
  }
  file_writer.attr_string(root, kContentSha256, digest.sha256_hex(), rp);
}

// ---- reading and validation ----

struct Range {
  double lo, hi;
  bool lo_open, hi_open;
  static Range open01() { return {0, 1, true, true}; }
  static Range non_negative() { return {0, INFINITY, false, true}; }
  static Range positive() { return {0, INFINITY, true, true}; }
  static Range closed(double a, double b) { return {a, b, false, false}; }
  bool contains(double v) const {
    if (lo_open ? !(v > lo) : !(v >= lo)) return false;
    if (hi_open ? !(v < hi) : !(v <= hi)) return false;
    return true;
  }
  std::string text() const {
    const std::string h = std::isinf(hi) ? "inf" : fmt::format("{:g}", hi);
    return fmt::format("{}{:g}, {}{}", lo_open ? "(" : "[", lo, h, (hi_open || std::isinf(hi)) ? ")" : "]");
  }
};

std::string index_text(std::size_t flat, const std::vector<hsize_t>& dims) {
  if (dims.size() <= 1) return fmt::format("at index {}", flat);
  std::vector<std::size_t> idx(dims.size());
  for (std::size_t d = dims.size(); d-- > 0;) {
    idx[d] = flat % dims[d];
    flat /= dims[d];
  }
  std::string s = "at index [";
  for (std::size_t d = 0; d < idx.size(); ++d) s += (d ? ", " : "") + std::to_string(idx[d]);
  return s + "]";
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "a scalar";
  std::string s = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
  return s + "]";
}

// Checks every value against `r`; reports the first bad one (and how many more).
bool check_values(const DoubleArray& a, const std::string& path, const Range& r, const Problems& p) {
  std::size_t bad = 0;
  std::string first;
  for (std::size_t i = 0; i < a.values.size(); ++i) {
    const double v = a.values[i];
    const std::string where = a.dims.empty() ? "" : " " + index_text(i, a.dims);
    std::string msg;
    if (!std::isfinite(v))
      msg = fmt::format("value {}{} is not finite", v, where);
    else if (!r.contains(v))
      msg = fmt::format("value {:g}{} out of range {}", v, where, r.text());
    if (!msg.empty() && bad++ == 0) first = msg;
  }
  if (bad == 0) return true;
  p.add(path, bad > 1 ? fmt::format("{} (and {} more)", first, bad - 1) : first);
  return false;
}

bool check_shape(const DoubleArray& a, const std::vector<hsize_t>& expected, const std::string& path,
                 const Problems& p, const std::string& why = "") {
  if (a.dims == expected) return true;
  p.add(path, "wrong shape " + shape_text(a.dims) + ", expected " + shape_text(expected) + why);
  return false;
}

// A dataset of known shape and range; nullopt (with problems recorded) otherwise.
std::optional<DoubleArray> read_checked(hid_t loc, const std::string& name, const std::string& gp,
                                        const std::vector<hsize_t>& shape, const Range& r, const Problems& p,
                                        const std::string& why = "") {
  const std::string path = h5::join(gp, name);
  auto a = h5::read_doubles(loc, name, path, p);
  if (!a) return std::nullopt;
  if (!check_shape(*a, shape, path, p, why)) return std::nullopt;
  if (!check_values(*a, path, r, p)) return std::nullopt;
  return a;
}

// The dataset that sets a group's lobe count: shape [N] with 1 to `max_lobes` lobes, values
// in `r`; the group's lobe_count attribute must agree. `*n` = N (0 when the shape is unreadable).
std::optional<DoubleArray> read_lobe_count_dataset(hid_t g, const std::string& name, const std::string& gp,
                                                   const Range& r, const Problems& p, hsize_t* n,
                                                   hsize_t max_lobes = 3) {
  *n = 0;
  const std::string path = h5::join(gp, name);
  auto a = h5::read_doubles(g, name, path, p);
  if (a) {
    if (a->dims.size() != 1 || a->dims[0] < 1 || a->dims[0] > max_lobes) {
      p.add(path, fmt::format("wrong shape {}, expected [N] with 1 to {} lobes", shape_text(a->dims), max_lobes));
      a.reset();
    } else {
      *n = a->dims[0];
      if (!check_values(*a, path, r, p)) a.reset();
    }
  }
  if (auto lc = h5::read_attr_int(g, "lobe_count", gp, p); lc && *n > 0 && *lc != static_cast<std::int64_t>(*n))
    p.add(h5::attr_path(gp, "lobe_count"), fmt::format("is {} but {} has {} lobes", *lc, path, *n));
  return a;
}

// Checks /conventions against the format's (`version`: as the file states it) and returns the
// colour space its "values" states.
std::string check_conventions(hid_t root, const std::string& rp, std::optional<std::int64_t> version,
                              const Problems& p) {
  std::string colour_space = colour::kCameraRgb;
  const std::string gp = h5::join(rp, "conventions");
  Handle g = h5::open_group(root, "conventions", gp, p);
  if (!g) return colour_space;
  const bool v3 = version && *version >= 3;
  // Without a readable version (a problem of its own) every convention is checked.
  const std::int64_t rules = version ? *version : kAxfFormatVersion;
  const auto versions = [](int since) {
    return since == kAxfFormatVersion ? fmt::format("version {}", since)
                                      : fmt::format("versions {} to {}", since, kAxfFormatVersion);
  };
  for (const auto& [k, v] : kConventions) {
    const int since = convention_since(k);
    if (rules < since) continue;  // an older file lacks it; one that has it is not judged by it
    auto s = h5::read_attr_string(g.get(), k, gp, p);
    if (!s) continue;
    if (k == "values" && v3) {
      if (*s == axf_values_convention(colour::kLinearSrgb)) colour_space = colour::kLinearSrgb;
      else if (*s != axf_values_convention(colour::kCameraRgb))
        p.add(h5::attr_path(gp, k), "states a colour space the format (" + versions(3) + ") does not define (\"" +
                                        *s + "\"); expected \"" + axf_values_convention(colour::kLinearSrgb) +
                                        "\" or \"" + axf_values_convention(colour::kCameraRgb) + "\"");
    } else if (*s != v) {
      p.add(h5::attr_path(gp, k), "states a different convention than the format (" + versions(since) +
                                      ") defines (\"" + *s + "\"); expected \"" + v + "\"");
    }
  }
  return colour_space;
}

// A section (group) of a paint that a reader checks: opened (a problem when it is missing;
// the reader then gives nothing) with the problems found before it, so that the reader
// gives nothing either when reading it found any.
struct SectionRead {
  std::string path;
  Handle group;
  std::size_t problems_before = 0;
  explicit operator bool() const { return static_cast<bool>(group); }
  hid_t id() const { return group.get(); }
  bool clean(const Problems& p) const { return p.list->size() == problems_before; }
};

SectionRead open_section(hid_t root, const std::string& rp, const char* name, const Problems& p) {
  SectionRead s;
  s.path = h5::join(rp, name);
  s.group = h5::open_group(root, name, s.path, p);
  s.problems_before = p.list->size();
  return s;
}

std::optional<brdf::AxfCarPaintParams> read_carpaint(hid_t root, const std::string& rp, const Problems& p,
                                                     std::optional<AxfCarPaintStddev>* stddev) {
  const SectionRead g = open_section(root, rp, "carpaint", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  brdf::AxfCarPaintParams c;
  if (auto v = read_checked(g.id(), "ior", gp, {}, Range::closed(1, 3), p)) c.ior = v->values[0];
  if (auto v = read_checked(g.id(), "diffuse", gp, {}, Range::non_negative(), p)) c.diffuse = v->values[0];

  // The lobe count comes from ct_coeffs; the other lobe datasets and lobe_count must agree.
  hsize_t n = 0;
  auto coeffs = read_lobe_count_dataset(g.id(), "ct_coeffs", gp, Range::non_negative(), p, &n);
  std::optional<DoubleArray> spreads, f0s;
  if (n > 0) {
    const std::string why = " (one per lobe of ct_coeffs)";
    spreads = read_checked(g.id(), "ct_spreads", gp, {n}, Range::open01(), p, why);
    f0s = read_checked(g.id(), "ct_f0s", gp, {n}, Range::open01(), p, why);
  } else {
    // Still report what is wrong with them on their own.
    h5::read_doubles(g.id(), "ct_spreads", h5::join(gp, "ct_spreads"), p);
    h5::read_doubles(g.id(), "ct_f0s", h5::join(gp, "ct_f0s"), p);
  }
  if (coeffs && spreads && f0s)
    for (hsize_t k = 0; k < n; ++k) c.lobes.push_back({coeffs->values[k], spreads->values[k], f0s->values[k]});

  const std::string tp = h5::join(gp, "colour_table");
  auto table = h5::read_doubles(g.id(), "colour_table", tp, p);
  if (table) {
    const auto& d = table->dims;
    if (d.size() != 3 || d[2] != 3 || d[0] < 1 || d[1] < 1 || d[0] > 1024 || d[1] > 1024) {
      p.add(tp, "wrong shape " + shape_text(d) + ", expected [Nh, Ni, 3] with Nh, Ni in 1..1024");
      table.reset();
    } else if (!check_values(*table, tp, Range::non_negative(), p)) {
      table.reset();
    }
  }
  if (auto s = read_checked(g.id(), "colour_table_scale", gp, {}, Range::positive(), p)) c.chi.scale = s->values[0];
  if (table) {
    const hsize_t nh = table->dims[0], ni = table->dims[1];
    c.chi.theta_h_samples = static_cast<int>(nh);
    c.chi.theta_i_samples = static_cast<int>(ni);
    c.chi.rgb.resize(nh * ni);
    for (std::size_t i = 0; i < nh * ni; ++i)
      c.chi.rgb[i] = brdf::Rgb(table->values[3 * i], table->values[3 * i + 1], table->values[3 * i + 2]);
    // The sample positions must be the half-texel centres the indexing convention states.
    auto check_axis = [&](const std::string& name, hsize_t count, const char* axis) {
      auto a = read_checked(g.id(), name, gp, {count}, Range::closed(0, kHalfPi), p,
                            fmt::format(" (one per {} sample of colour_table)", axis));
      if (!a) return;
      const auto expect = theta_samples(static_cast<int>(count));
      for (std::size_t k = 0; k < count; ++k)
        if (std::abs(a->values[k] - expect[k]) > 1e-9) {
          p.add(h5::join(gp, name),
                fmt::format("value {:.12g} at index {} is not the sample centre {:.12g} = ({} + 0.5) / {} * pi/2", a->values[k],
                            k, expect[k], k, count));
          return;
        }
    };
    check_axis("colour_table_theta_h_rad", nh, "theta_h");
    check_axis("colour_table_theta_i_rad", ni, "theta_i");
  } else {
    h5::read_doubles(g.id(), "colour_table_theta_h_rad", h5::join(gp, "colour_table_theta_h_rad"), p);
    h5::read_doubles(g.id(), "colour_table_theta_i_rad", h5::join(gp, "colour_table_theta_i_rad"), p);
  }
  // Standard deviations: all five or none.
  const std::vector<std::string> std_names = {"ior_std", "diffuse_std", "ct_coeffs_std", "ct_spreads_std",
                                              "ct_f0s_std"};
  int present = 0;
  for (const auto& sn : std_names) present += h5::exists(g.id(), sn, h5::join(gp, sn), p) ? 1 : 0;
  if (present > 0 && n > 0) {
    const std::string swhy = " (the shape of the parameter)";
    auto is = read_checked(g.id(), "ior_std", gp, {}, Range::non_negative(), p, swhy);
    auto ds = read_checked(g.id(), "diffuse_std", gp, {}, Range::non_negative(), p, swhy);
    auto cs = read_checked(g.id(), "ct_coeffs_std", gp, {n}, Range::non_negative(), p, swhy);
    auto ss = read_checked(g.id(), "ct_spreads_std", gp, {n}, Range::non_negative(), p, swhy);
    auto fs = read_checked(g.id(), "ct_f0s_std", gp, {n}, Range::non_negative(), p, swhy);
    if (is && ds && cs && ss && fs) {
      AxfCarPaintStddev sd;
      sd.ior = is->values[0];
      sd.diffuse = ds->values[0];
      for (hsize_t k = 0; k < n; ++k) sd.lobes.push_back({cs->values[k], ss->values[k], fs->values[k]});
      *stddev = sd;
    }
  }
  if (!g.clean(p)) return std::nullopt;
  return c;
}

std::optional<AxfCookTorrance> read_cook_torrance(hid_t root, const std::string& rp, const Problems& p) {
  const SectionRead g = open_section(root, rp, "cook_torrance", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  AxfCookTorrance ct;
  hsize_t n = 0;
  auto m = read_lobe_count_dataset(g.id(), "m", gp, Range::open01(), p, &n);
  const std::string why = " (one per lobe of m)";
  auto kd = read_checked(g.id(), "kd", gp, {3}, Range::non_negative(), p);
  std::optional<DoubleArray> ks, r;
  if (n > 0) {
    ks = read_checked(g.id(), "ks", gp, {n, 3}, Range::non_negative(), p, why);
    r = read_checked(g.id(), "r", gp, {n}, Range::open01(), p, why);
  } else {
    h5::read_doubles(g.id(), "ks", h5::join(gp, "ks"), p);
    h5::read_doubles(g.id(), "r", h5::join(gp, "r"), p);
  }
  if (kd) ct.params.kd = brdf::Rgb(kd->values[0], kd->values[1], kd->values[2]);
  if (m && ks && r)
    for (hsize_t k = 0; k < n; ++k)
      ct.params.lobes.push_back({brdf::Rgb(ks->values[3 * k], ks->values[3 * k + 1], ks->values[3 * k + 2]),
                                 m->values[k], r->values[k]});

  // Standard deviations: all four or none.
  const std::vector<std::string> std_names = {"kd_std", "ks_std", "m_std", "r_std"};
  int present = 0;
  for (const auto& s : std_names) present += h5::exists(g.id(), s, h5::join(gp, s), p) ? 1 : 0;
  if (present > 0 && n > 0) {
    const std::string swhy = " (the shape of the parameter)";
    auto kds = read_checked(g.id(), "kd_std", gp, {3}, Range::non_negative(), p, swhy);
    auto kss = read_checked(g.id(), "ks_std", gp, {n, 3}, Range::non_negative(), p, swhy);
    auto ms = read_checked(g.id(), "m_std", gp, {n}, Range::non_negative(), p, swhy);
    auto rs = read_checked(g.id(), "r_std", gp, {n}, Range::non_negative(), p, swhy);
    if (kds && kss && ms && rs) {
      CookTorranceStddev sd;
      sd.kd = brdf::Rgb(kds->values[0], kds->values[1], kds->values[2]);
      for (hsize_t k = 0; k < n; ++k)
        sd.lobes.push_back({brdf::Rgb(kss->values[3 * k], kss->values[3 * k + 1], kss->values[3 * k + 2]),
                            ms->values[k], rs->values[k]});
      ct.stddev = sd;
    }
  }
  if (!g.clean(p)) return std::nullopt;
  return ct;
}

std::optional<brdf::CosineLobeParams> read_cosine_lobes(hid_t root, const std::string& rp, const Problems& p) {
  const SectionRead g = open_section(root, rp, "cosine_lobes", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  brdf::CosineLobeParams cl;
  hsize_t n = 0;
  const std::string ep = h5::join(gp, "exponents");
  auto e = read_lobe_count_dataset(g.id(), "exponents", gp,
                                   Range::closed(brdf::kMinLobeExponent, brdf::kMaxLobeExponent), p, &n,
                                   static_cast<hsize_t>(brdf::kMaxCosineLobes));
  if (e) {
    for (hsize_t k = 1; k < n; ++k)
      if (!(e->values[k] > e->values[k - 1])) {
        p.add(ep, fmt::format("value {:g} at index {} is not above the one before ({:g}): exponents increase",
                              e->values[k], k, e->values[k - 1]));
        e.reset();
        break;
      }
  }
  auto kd = read_checked(g.id(), "kd", gp, {3}, Range::non_negative(), p);
  std::optional<DoubleArray> kg, kdd;
  if (n > 0) {
    const std::string why = " (one row per exponent)";
    kg = read_checked(g.id(), "kg", gp, {n, 3}, Range::non_negative(), p, why);
    kdd = read_checked(g.id(), "kdd", gp, {n, 3}, Range::non_negative(), p, why);
  } else {
    h5::read_doubles(g.id(), "kg", h5::join(gp, "kg"), p);
    h5::read_doubles(g.id(), "kdd", h5::join(gp, "kdd"), p);
  }
  if (kd) cl.kd = brdf::Rgb(kd->values[0], kd->values[1], kd->values[2]);
  if (e && kg && kdd) {
    cl.exponents = e->values;
    for (hsize_t k = 0; k < n; ++k) {
      cl.kg.emplace_back(kg->values[3 * k], kg->values[3 * k + 1], kg->values[3 * k + 2]);
      cl.kdd.emplace_back(kdd->values[3 * k], kdd->values[3 * k + 1], kdd->values[3 * k + 2]);
    }
  }
  if (!g.clean(p)) return std::nullopt;
  // The checks above are the model's rules; should they ever differ, the model's own wins.
  if (const std::string problem = brdf::cosine_lobes_problem(cl); !problem.empty()) {
    p.add(gp, problem);
    return std::nullopt;
  }
  return cl;
}

std::optional<brdf::FlakeSpec> read_flakes(hid_t root, const std::string& rp, std::size_t lobe_count,
                                           const Problems& p) {
  const SectionRead g = open_section(root, rp, "flakes", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  brdf::FlakeSpec f;
  if (auto v = read_checked(g.id(), "density", gp, {}, Range::positive(), p)) f.density = v->values[0];
  if (auto v = read_checked(g.id(), "roughness", gp, {}, Range::open01(), p)) f.roughness = v->values[0];
  if (auto v = read_checked(g.id(), "lifetime_deg", gp, {}, Range{0, 45, true, false}, p))
    f.lifetime_deg = v->values[0];
  const std::string lp = h5::join(gp, "lobes");
  if (auto l = h5::read_ints(g.id(), "lobes", lp, p)) {
    if (l->dims.size() != 1) {
      p.add(lp, "wrong shape " + shape_text(l->dims) + ", expected [K] (1-based lobe numbers)");
    } else {
      std::set<std::int64_t> seen;
      for (std::size_t i = 0; i < l->values.size(); ++i) {
        const std::int64_t v = l->values[i];
        if (v < 1 || (lobe_count > 0 && v > static_cast<std::int64_t>(lobe_count))) {
          p.add(lp, fmt::format("value {} at index {} out of range [1, {}] (1-based lobe numbers)", v, i, lobe_count));
          break;
        }
        if (!seen.insert(v).second) {
          p.add(lp, fmt::format("lobe {} is listed twice", v));
          break;
        }
        f.lobes.push_back(static_cast<int>(v - 1));
      }
    }
  }
  // The flakes' colour (version 4): all four or none.
  const std::vector<std::string> colour_names = {"tint_sd", "interference", "interference_chroma",
                                                 "interference_shift_deg"};
  int present = 0;
  for (const auto& s : colour_names) present += h5::exists(g.id(), s, h5::join(gp, s), p) ? 1 : 0;
  if (present > 0) {
    auto sd = read_checked(g.id(), "tint_sd", gp, {}, Range::closed(0, 1), p);
    auto fr = read_checked(g.id(), "interference", gp, {}, Range::closed(0, 1), p);
    auto ch = read_checked(g.id(), "interference_chroma", gp, {}, Range{0, 1, true, false}, p);
    auto sh = read_checked(g.id(), "interference_shift_deg", gp, {}, Range::closed(-90, 90), p);
    if (sd && fr && ch && sh) {
      f.tint_sd = sd->values[0];
      f.interference = fr->values[0];
      f.interference_chroma = ch->values[0];
      f.interference_shift_deg = sh->values[0];
    }
  }
  if (!g.clean(p)) return std::nullopt;
  return f;
}

std::optional<FlakeStats> read_flake_stats(hid_t root, const std::string& rp, const Problems& p) {
  const SectionRead g = open_section(root, rp, "flake_stats", p);
  if (!g) return std::nullopt;
  const std::string jp = h5::join(g.path, "json");
  std::optional<FlakeStats> out;
  if (auto text = h5::read_strings(g.id(), "json", jp, p)) {
    if (text->size() != 1) {
      p.add(jp, fmt::format("{} strings, expected 1 (the flakes.json text)", text->size()));
    } else {
      try {
        out = flakes_from_json(Json::parse(text->front()), jp);
      } catch (const Json::exception& e) {
        p.add(jp, std::string("not JSON: ") + e.what());
      } catch (const Error& e) {
        p.list->push_back(e.what());
      }
    }
  }
  if (!g.clean(p)) return std::nullopt;
  return out;
}

std::optional<FlakeBtf> read_flake_btf(hid_t root, const std::string& rp, const Problems& p) {
  const SectionRead g = open_section(root, rp, "flake_btf", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  if (auto c = h5::read_attr_string(g.id(), "bin_convention", gp, p); c && *c != kFlakeBinConvention)
    p.add(h5::attr_path(gp, "bin_convention"),
          "states a different bin convention than the format defines (\"" + *c + "\"); expected \"" +
              kFlakeBinConvention + "\"");
  FlakeBtf b;
  auto scalar_int = [&](const char* name, int* v) {
    const std::string path = h5::join(gp, name);
    if (auto a = h5::read_ints(g.id(), name, path, p)) {
      if (!a->dims.empty()) p.add(path, "wrong shape " + shape_text(a->dims) + ", expected a scalar");
      else if (a->values[0] < 0 || a->values[0] > 1024) p.add(path, fmt::format("value {} outside [0, 1024]", a->values[0]));
      else *v = static_cast<int>(a->values[0]);
    }
  };
  scalar_int("num_thetaF", &b.num_theta_f);
  scalar_int("num_thetaI", &b.num_theta_i);
  scalar_int("max_thetaI", &b.max_theta_i);
  scalar_int("texture_size", &b.texture_size);
  if (auto v = read_checked(g.id(), "ior", gp, {}, Range::closed(1, 3), p)) b.ior = v->values[0];
  const std::string lp = h5::join(gp, "thetaFI_sliceLUT");
  if (auto l = h5::read_ints(g.id(), "thetaFI_sliceLUT", lp, p)) {
    if (l->dims.size() != 1) p.add(lp, "wrong shape " + shape_text(l->dims) + ", expected [max_thetaI + 1]");
    else
      for (std::int64_t v : l->values) b.slice_lut.push_back(v < 0 || v > 255 ? -1 : static_cast<int>(v));
  }
  if (auto t = h5::read_doubles(g.id(), "BTFflakes", h5::join(gp, "BTFflakes"), p)) {
    const auto want = static_cast<hsize_t>(b.texture_size);
    if (t->dims.size() != 4 || t->dims[1] != want || t->dims[2] != want || t->dims[3] != 3)
      p.add(h5::join(gp, "BTFflakes"), "wrong shape " + shape_text(t->dims) + ", expected [slices, texture_size, texture_size, 3]");
    b.texels = std::move(t->values);
  }
  if (auto m = h5::read_doubles(g.id(), "slice_mean", h5::join(gp, "slice_mean"), p)) b.slice_mean = std::move(m->values);
  if (g.clean(p) && !b.slice_lut.empty()) {
    try {
      b.check(gp);
    } catch (const DataError& e) {
      p.list->push_back(e.what());
    }
  } else if (g.clean(p)) {
    p.add(lp, "empty (expected max_thetaI + 1 entries)");
  }
  if (!g.clean(p)) return std::nullopt;
  return b;
}

std::optional<AxfFitQuality> read_fit_quality(hid_t root, const std::string& rp, const Problems& p) {
  const SectionRead g = open_section(root, rp, "fit_quality", p);
  if (!g) return std::nullopt;
  const std::string& gp = g.path;
  AxfFitQuality q;
  if (auto v = read_checked(g.id(), "log_rms", gp, {}, Range::non_negative(), p)) q.log_rms = v->values[0];
  const std::string bp = h5::join(gp, "bins_used");
  if (auto b = h5::read_ints(g.id(), "bins_used", bp, p)) {
    if (!b->dims.empty())
      p.add(bp, "wrong shape " + shape_text(b->dims) + ", expected a scalar");
    else if (b->values[0] < 0)
      p.add(bp, fmt::format("value {} out of range [0, inf)", b->values[0]));
    else
      q.bins_used = b->values[0];
  }
  if (auto c = h5::read_attr_int(g.id(), "converged", gp, p)) {
    if (*c != 0 && *c != 1)
      p.add(h5::attr_path(gp, "converged"), fmt::format("value {} is not 0 or 1", *c));
    else
      q.converged = *c == 1;
  }
  if (auto s = h5::read_attr_string(g.id(), "residual_json", gp, p)) {
    try {
      q.residual = Json::parse(*s);
      if (!q.residual.is_object()) p.add(h5::attr_path(gp, "residual_json"), "is not a JSON object");
    } catch (const nlohmann::json::exception& e) {
      p.add(h5::attr_path(gp, "residual_json"), std::string("is not valid JSON: ") + e.what());
    }
  }
  if (!g.clean(p)) return std::nullopt;
  return q;
}

AxfProvenance read_provenance(hid_t root, const std::string& rp, const Problems& p) {
  AxfProvenance pv;
  const std::string gp = h5::join(rp, "provenance");
  Handle g = h5::open_group(root, "provenance", gp, p);
  if (!g) return pv;
  auto text = [&](const char* name, std::string& out) {
    if (auto s = h5::read_attr_string(g.get(), name, gp, p)) out = *s;
  };
  text("sample_name", pv.sample_name);
  text("measured_utc", pv.measured_utc);
  text("exported_utc", pv.exported_utc);
  text("rig_name", pv.rig_name);
  text("session_sha256", pv.session_sha256);
  text("software_version", pv.software_version);
  text("source", pv.source);
  for (const char* name : {"measured_utc", "exported_utc"}) {
    const std::string& v = std::strcmp(name, "measured_utc") == 0 ? pv.measured_utc : pv.exported_utc;
    if (!v.empty() && parse_utc_timestamp(v) < 0)
      p.add(h5::attr_path(gp, name), "'" + v + "' is not an ISO 8601 UTC time (YYYY-MM-DDTHH:MM:SSZ)");
  }
  if (!pv.session_sha256.empty() && !valid_sha256(pv.session_sha256))
    p.add(h5::attr_path(gp, "session_sha256"), "'" + pv.session_sha256 + "' is not a SHA-256 (64 lower-case hex digits)");
  auto files = h5::read_strings(g.get(), "calibration_files", h5::join(gp, "calibration_files"), p);
  auto sums = h5::read_strings(g.get(), "calibration_sha256", h5::join(gp, "calibration_sha256"), p);
  if (files && sums) {
    if (files->size() != sums->size()) {
      p.add(h5::join(gp, "calibration_sha256"),
            fmt::format("has {} entries but calibration_files has {}", sums->size(), files->size()));
    } else {
      for (std::size_t i = 0; i < files->size(); ++i) {
        if (!valid_sha256((*sums)[i]))
          p.add(h5::join(gp, "calibration_sha256"),
                fmt::format("value '{}' at index {} is not a SHA-256 (64 lower-case hex digits)", (*sums)[i], i));
        pv.calibration_sha256.emplace_back((*files)[i], (*sums)[i]);
      }
    }
  }
  return pv;
}

// Reads and checks a format_version attribute.
std::optional<std::int64_t> read_version(hid_t root, const std::string& rp, const Problems& p) {
  auto v = h5::read_attr_int(root, "format_version", rp, p);
  if (!v) return v;
  if (*v > kAxfFormatVersion)
    p.add(h5::attr_path(rp, "format_version"),
          fmt::format("{} is newer than this software reads ({}): update paintlab", *v, kAxfFormatVersion));
  else if (*v < 1)
    p.add(h5::attr_path(rp, "format_version"), fmt::format("{} is not a format version (>= 1)", *v));
  return v;
}

// Checks the content checksum against what was read (`digest`). Files of format version 2
// carry it; version 1 files have none and are read as before. A mismatch goes first among
// the problems found since `first`: it is the one that says the file is damaged.
void check_content(hid_t root, const std::string& rp, std::optional<std::int64_t> version, const h5::Digest& digest,
                   std::size_t first, const Problems& p) {
  if (!version || *version > kAxfFormatVersion) return;  // unknown rules: the version problem says so
  std::vector<std::string> own;
  const Problems q{&own, p.file};
  if (*version < 2 && !h5::has_attr(root, kContentSha256, rp, q)) return;
  const std::string where = h5::attr_path(rp, kContentSha256);
  std::string problem;
  if (auto stored = h5::read_attr_string(root, kContentSha256, rp, q)) {
    const std::string actual = digest.sha256_hex();
    if (*stored != actual)
      problem = where + ": '" + *stored + "' does not match the content read (SHA-256 " + actual +
                "): the file is damaged or was changed after it was written";
  } else {
    problem = own.empty() ? where + ": missing" : own.front();
    problem += fmt::format(" (a file of format version {} carries the SHA-256 of its content; damaged file?)", *version);
  }
  if (!problem.empty())
    p.list->insert(p.list->begin() + static_cast<std::ptrdiff_t>(std::min(first, p.list->size())), problem);
}

// Reads one paint rooted at `root` (whose HDF5 path is rp), recording every problem.
AxfPaint read_paint(hid_t root, const std::string& rp, const Problems& problems,
                    std::optional<std::int64_t>* version_out = nullptr) {
  const std::size_t first = problems.list->size();
  h5::Digest digest(rp);
  const Problems p = problems.with_digest(&digest);
  AxfPaint paint;
  if (auto f = h5::read_attr_string(root, "format", rp, p); f && *f != kAxfFormat)
    p.add(h5::attr_path(rp, "format"), "'" + *f + "' is not '" + kAxfFormat + "'");
  const auto version = read_version(root, rp, p);
  if (version_out) *version_out = version;
  if (auto n = h5::read_attr_string(root, "paint_name", rp, p)) {
    paint.name = *n;
    if (!valid_name(*n)) p.add(h5::attr_path(rp, "paint_name"), "'" + *n + "' is not a paint name ([a-z0-9._-]+)");
  }
  if (auto m = h5::read_attr_string(root, "model", rp, p)) {
    paint.model = *m;
    if (*m != "axf-carpaint" && *m != "cook-torrance" && *m != "cosine-lobes")
      p.add(h5::attr_path(rp, "model"), "'" + *m + "' is not 'axf-carpaint', 'cook-torrance' or 'cosine-lobes'");
    else if (*m == "cosine-lobes" && version && *version < 5)
      p.add(h5::attr_path(rp, "model"), fmt::format("'cosine-lobes' is a model of format version 5, not {}", *version));
  }
  paint.colour_space = check_conventions(root, rp, version, p);
  const bool need_carpaint = paint.model == "axf-carpaint";
  const bool need_ct = paint.model == "cook-torrance";
  const bool need_cl = paint.model == "cosine-lobes";
  auto present = [&](const char* name) { return h5::exists(root, name, h5::join(rp, name), p); };
  if (need_carpaint || present("carpaint")) paint.carpaint = read_carpaint(root, rp, p, &paint.carpaint_stddev);
  if (need_ct || present("cook_torrance")) paint.cook_torrance = read_cook_torrance(root, rp, p);
  // Files before version 5 have no /cosine_lobes, and a group of that name in one is not ours.
  if (need_cl || (version && *version >= 5 && present("cosine_lobes")))
    paint.cosine_lobes = read_cosine_lobes(root, rp, p);
  if (present("flakes")) {
    std::size_t lobes = 0;
    if (paint.model == "axf-carpaint" && paint.carpaint) lobes = paint.carpaint->lobes.size();
    if (paint.model == "cook-torrance" && paint.cook_torrance) lobes = paint.cook_torrance->params.lobes.size();
    // The simulator's flakes carry lobes of the model; cosine lobes are none of those (and a
    // cosine-lobes paint file cannot have [flakes]). Read all the same: the checksum covers them.
    if (need_cl)
      p.add(h5::join(rp, "flakes"), "a cosine-lobes paint has no lobes for flakes to carry (paint-files.md \"Sparkle\")");
    paint.flakes = read_flakes(root, rp, lobes, p);
  }
  if (present("flake_stats")) paint.flake_stats = read_flake_stats(root, rp, p);
  if (present("flake_btf")) paint.flake_btf = read_flake_btf(root, rp, p);
  if (paint.flake_stats && paint.flake_btf &&
      (paint.flake_btf->num_theta_f != paint.flake_stats->options.num_theta_f ||
       paint.flake_btf->num_theta_i != paint.flake_stats->options.num_theta_i))
    p.add(h5::join(rp, "flake_btf"), fmt::format("{} x {} slice bins, but /flake_stats has {} x {}",
                                                 paint.flake_btf->num_theta_f, paint.flake_btf->num_theta_i,
                                                 paint.flake_stats->options.num_theta_f,
                                                 paint.flake_stats->options.num_theta_i));
  if (present("fit_quality")) paint.fit_quality = read_fit_quality(root, rp, p);
  paint.provenance = read_provenance(root, rp, p);
  check_content(root, rp, version, digest, first, problems);
  return paint;
}

// Opens a file for reading; records one problem (or throws IoError when `throw_io`) when
// it cannot be opened.
std::optional<h5::InputFile> open_file(const fs::path& path, const Problems& p, bool throw_io) {
  h5::silence_errors();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    if (throw_io) throw IoError(path.string(), "cannot read", ENOENT);
    p.add(path.string(), "no such file");
    return std::nullopt;
  }
  std::string problem;
  auto in = h5::open_input(path.string(), &problem);
  if (!in) p.add("/", problem);
  return in;
}

// The root group of an open file; records a problem when it cannot be opened.
Handle open_root(hid_t file, const Problems& p) {
  Handle root(H5Gopen2(file, "/", H5P_DEFAULT), H5Gclose);
  if (!root) p.add("/", "root group cannot be opened (damaged file?)");
  return root;
}

// Builds a file in memory (`write` fills its root group) and returns its bytes.
std::string build_image(const std::string& what, const std::function<void(hid_t root, const Writer& w)>& write) {
  h5::MemoryFile f(what);
  {
    Handle root(H5Gopen2(f.get(), "/", H5P_DEFAULT), H5Gclose);
    if (!root) throw IoError(what, "cannot write HDF5 object /");
    write(root.get(), Writer(what));
  }
  return f.finish();
}

AxfPaint with_defaults(AxfPaint paint) {
  if (paint.provenance.exported_utc.empty()) paint.provenance.exported_utc = utc_timestamp();
  if (paint.provenance.software_version.empty()) paint.provenance.software_version = software_version();
  return paint;
}

[[noreturn]] void throw_problems(const std::string& where, const std::vector<std::string>& problems) {
  std::string msg = where + ": " + problems.front();
  if (problems.size() > 1) msg += fmt::format(" (and {} more problems; see paintlab axf validate)", problems.size() - 1);
  throw DataError(msg);
}

}  // namespace

const std::vector<std::pair<std::string, std::string>>& axf_conventions() { return kConventions; }
int axf_convention_since(const std::string& name) { return convention_since(name); }

std::string axf_values_convention(const std::string& colour_space) {
  return colour_space + ": no gamma, no sRGB transfer curve, no tone mapping";
}

bool AxfCookTorrance::operator==(const AxfCookTorrance& o) const {
  if (!(params == o.params) || stddev.has_value() != o.stddev.has_value()) return false;
  if (!stddev) return true;
  return (stddev->kd == o.stddev->kd).all() && stddev->lobes == o.stddev->lobes;
}

bool AxfFitQuality::operator==(const AxfFitQuality& o) const {
  return log_rms == o.log_rms && bins_used == o.bins_used && converged == o.converged && residual == o.residual;
}

brdf::PaintSpec AxfPaint::paint_spec() const {
  brdf::PaintSpec s;
  s.name = name;
  if (model == "axf-carpaint") {
    if (!carpaint) throw DataError("paint '" + name + "': model axf-carpaint but no /carpaint");
    s.params = *carpaint;
  } else if (model == "cosine-lobes") {
    if (!cosine_lobes) throw DataError("paint '" + name + "': model cosine-lobes but no /cosine_lobes");
    s.params = *cosine_lobes;
  } else {
    if (!cook_torrance) throw DataError("paint '" + name + "': model cook-torrance but no /cook_torrance");
    s.params = cook_torrance->params;
  }
  s.flakes = flakes;
  return s;
}

AxfPaint axf_from_paint(const brdf::PaintSpec& spec) {
  AxfPaint a;
  a.name = spec.name;
  a.model = spec.model();
  if (const auto* ct = spec.cook_torrance()) {
    a.cook_torrance = AxfCookTorrance{*ct, std::nullopt};
  } else if (const auto* cp = spec.axf_carpaint()) {
    a.carpaint = *cp;
  } else if (const auto* cl = spec.cosine_lobes()) {
    a.cosine_lobes = *cl;
  } else {
    throw DataError("paint '" + spec.name + "': " + spec.model() +
                    " paints have no AxF-like form (only cook-torrance, axf-carpaint and cosine-lobes): measure and "
                    "fit it");
  }
  a.flakes = spec.flakes;
  a.colour_space = colour::kLinearSrgb;
  if (!spec.source.empty()) a.provenance.source = spec.source.string();
  return a;
}

AxfPaint axf_from_fit_json(const Json& fit, const std::string& where) {
  if (!fit.is_object()) throw DataError(where + ": expected a JSON object (a fit)");
  const brdf::PaintSpec spec = brdf::paint_from_json(fit, where);
  AxfPaint a = axf_from_paint(spec);
  a.provenance.source = where;
  a.colour_space = colour::kCameraRgb;
  if (fit.contains("input") && fit["input"].is_object() && fit["input"].contains("colour_space")) {
    const Json& cs = fit["input"]["colour_space"];
    if (!cs.is_string() || (cs != colour::kLinearSrgb && cs != colour::kCameraRgb))
      throw DataError(fmt::format("{}: input.colour_space must be \"{}\" or \"{}\"", where, colour::kLinearSrgb,
                                  colour::kCameraRgb));
    a.colour_space = cs.get<std::string>();
  }
  // A standard deviation the fit could not determine is null in fit.json (a lobe without
  // weight, a failed covariance, a fit stopped before converging); the file holds all of
  // them or none, so such a fit's are left out (with a warning), the fit itself is read.
  const std::function<bool(const Json&)> has_null = [&](const Json& j) {
    if (j.is_null()) return true;
    if (j.is_object() || j.is_array())
      for (const auto& e : j)
        if (has_null(e)) return true;
    return false;
  };
  const bool stddev_known = !fit.contains("stddev") || !has_null(fit["stddev"]);
  if (!stddev_known)
    spdlog::warn("{}: some standard deviations are undetermined (null); the paint is read without them", where);
  if (a.cook_torrance && fit.contains("stddev") && stddev_known) {
    const Json& s = fit["stddev"];
    const std::string sw = where + ": key 'stddev'";
    if (!s.is_object()) throw DataError(sw + ": expected an object");
    CookTorranceStddev sd;
    const auto kd = json_get<std::vector<double>>(s, "kd", sw);
    if (kd.size() != 3) throw DataError(sw + ".kd: expected 3 numbers");
    sd.kd = brdf::Rgb(kd[0], kd[1], kd[2]);
    const Json lobes = json_get<Json>(s, "lobes", sw);
    if (!lobes.is_array() || lobes.size() != a.cook_torrance->params.lobes.size())
      throw DataError(sw + ".lobes: expected one entry per lobe (" +
                      std::to_string(a.cook_torrance->params.lobes.size()) + ")");
    for (std::size_t k = 0; k < lobes.size(); ++k) {
      const std::string lw = sw + fmt::format(".lobes[{}]", k);
      const auto ks = json_get<std::vector<double>>(lobes[k], "ks", lw);
      if (ks.size() != 3) throw DataError(lw + ".ks: expected 3 numbers");
      sd.lobes.push_back({brdf::Rgb(ks[0], ks[1], ks[2]), json_get<double>(lobes[k], "m", lw),
                          json_get<double>(lobes[k], "r", lw)});
    }
    a.cook_torrance->stddev = sd;
  }
  if (a.carpaint && fit.contains("stddev") && stddev_known) {
    const Json& s = fit["stddev"];
    const std::string sw = where + ": key 'stddev'";
    if (!s.is_object()) throw DataError(sw + ": expected an object");
    AxfCarPaintStddev sd;
    sd.ior = json_get<double>(s, "ior", sw);
    sd.diffuse = json_get<double>(s, "diffuse", sw);
    const Json lobes = json_get<Json>(s, "lobes", sw);
    if (!lobes.is_array() || lobes.size() != a.carpaint->lobes.size())
      throw DataError(sw + ".lobes: expected one entry per lobe (" + std::to_string(a.carpaint->lobes.size()) + ")");
    for (std::size_t k = 0; k < lobes.size(); ++k) {
      const std::string lw = sw + fmt::format(".lobes[{}]", k);
      sd.lobes.push_back({json_get<double>(lobes[k], "coefficient", lw), json_get<double>(lobes[k], "spread", lw),
                          json_get<double>(lobes[k], "f0", lw)});
    }
    a.carpaint_stddev = sd;
  }
  if (fit.contains("residual")) {
    const Json& r = fit["residual"];
    const std::string rw = where + ": key 'residual'";
    if (!r.is_object()) throw DataError(rw + ": expected an object");
    AxfFitQuality q;
    q.log_rms = json_get<double>(r, "log_rms", rw);
    q.bins_used = json_get<std::int64_t>(r, "bins_used", rw);
    q.residual = r;
    if (fit.contains("summary") && fit["summary"].is_object())
      q.converged = json_get_or<bool>(fit["summary"], "converged", true, where + ": key 'summary'");
    a.fit_quality = q;
  }
  return a;
}

AxfPaint merge_axf(AxfPaint base, const AxfPaint& other) {
  if (base.colour_space != other.colour_space)
    throw DataError(fmt::format("the paints are in different colour spaces ({} and {}): they are not one measurement",
                                base.colour_space, other.colour_space));
  if (other.carpaint) {
    if (base.carpaint) throw DataError("both paints hold an AxF car-paint form: give one fit per model");
    base.carpaint = other.carpaint;
    base.carpaint_stddev = other.carpaint_stddev;
  }
  if (other.cook_torrance) {
    if (base.cook_torrance) throw DataError("both paints hold a Cook-Torrance form: give one fit per model");
    base.cook_torrance = other.cook_torrance;
  }
  if (other.cosine_lobes) {
    if (base.cosine_lobes) throw DataError("both paints hold cosine-lobe weights: give them once");
    base.cosine_lobes = other.cosine_lobes;
  }
  if (!base.flakes) base.flakes = other.flakes;
  if (!base.flake_stats) {
    base.flake_stats = other.flake_stats;
    base.flake_btf = other.flake_btf;
  }
  if (!base.fit_quality) base.fit_quality = other.fit_quality;
  return base;
}

namespace {

// Validates (and reads) a library file: its root (with its own content checksum) and paints.
std::vector<AxfPaint> read_library(hid_t root, const Problems& problems, std::vector<std::string>* names,
                                   std::optional<std::int64_t>* version_out = nullptr) {
  std::vector<AxfPaint> out;
  const std::size_t first = problems.list->size();
  h5::Digest digest("/");
  const Problems p = problems.with_digest(&digest);
  h5::read_attr_string(root, "format", "/", p);
  const auto version = read_version(root, "/", p);
  if (version_out) *version_out = version;
  auto count = h5::read_attr_int(root, "paint_count", "/", p);
  check_content(root, "/", version, digest, first, problems);
  Handle group = h5::open_group(root, "paints", "/paints", problems);
  if (!group) return out;
  const auto members = h5::member_names(group.get(), "/paints", problems);
  if (count && *count != static_cast<std::int64_t>(members.size()))
    problems.add(h5::attr_path("/", "paint_count"),
                 fmt::format("is {} but /paints holds {} paints", *count, members.size()));
  for (const auto& name : members) {
    const std::string gp = "/paints/" + name;
    Handle g = h5::open_group(group.get(), name, gp, problems);
    if (!g) continue;
    AxfPaint paint = read_paint(g.get(), gp, problems);
    if (!paint.name.empty() && paint.name != name)
      problems.add(h5::attr_path(gp, "paint_name"), "'" + paint.name + "' differs from the group name '" + name + "'");
    if (names) names->push_back(name);
    out.push_back(std::move(paint));
  }
  return out;
}

// The problems the validator finds in a file built in memory.
std::vector<std::string> check_image(const std::string& bytes, const std::string& what, bool library) {
  h5::InputFile in(h5::open_image(bytes, what));
  std::vector<std::string> problems;
  const Problems p{&problems, &in};
  Handle root = open_root(in.get(), p);
  if (!root) return problems;
  if (library)
    read_library(root.get(), p, nullptr);
  else
    read_paint(root.get(), "/", p);
  return problems;
}

// The bytes of a paint's file, checked with exactly the validator's rules (DataError
// naming the field; IoError naming `what` when HDF5 fails).
std::string paint_image(const AxfPaint& paint, const std::string& what) {
  const std::string image =
      build_image(what, [&](hid_t root, const Writer& w) { write_paint(root, "/", paint, w); });
  const auto problems = check_image(image, what, false);
  if (!problems.empty()) throw_problems("paint '" + paint.name + "'", problems);
  return image;
}

}  // namespace

void check_axf_paint(const AxfPaint& paint) {
  // One set of rules: write the file in memory and read it back with the validator.
  (void)paint_image(paint, "paint '" + paint.name + "'");
}

void write_axf_file(const fs::path& path, const AxfPaint& input) {
  const AxfPaint paint = with_defaults(input);
  // Built and checked in memory first: HDF5 never writes to the disk, so a full disk is a
  // failed write of bytes (IoError, the old file kept), never a half-closed HDF5 file.
  write_file_atomic(path, paint_image(paint, path.string()));
}

AxfPaint read_axf_file(const fs::path& path) {
  std::vector<std::string> problems;
  auto in = open_file(path, Problems{&problems}, true);
  if (!in) throw_problems(path.string(), problems);
  const Problems p{&problems, &*in};
  Handle root = open_root(in->get(), p);
  if (!root) throw_problems(path.string(), problems);
  if (auto fmt_attr = h5::read_attr_string(root.get(), "format", "/", p); fmt_attr && *fmt_attr == kAxfLibraryFormat)
    throw DataError(path.string() + ": is a paint library file (" + kAxfLibraryFormat +
                    "), not a single paint: use paintlab library commands or read_axf_library_file");
  problems.clear();
  AxfPaint paint = read_paint(root.get(), "/", p);
  if (!problems.empty()) throw_problems(path.string(), problems);
  return paint;
}

void write_axf_library_file(const fs::path& path, const std::vector<AxfPaint>& input) {
  std::vector<AxfPaint> paints;
  std::set<std::string> names;
  for (const auto& p : input) {
    paints.push_back(with_defaults(p));
    check_axf_paint(paints.back());
    if (!names.insert(p.name).second) throw DataError("paint '" + p.name + "' is listed twice");
  }
  const std::string image = build_image(path.string(), [&](hid_t root, const Writer& w) {
    h5::Digest digest("/");
    const Writer rw = w.with_digest(&digest);
    rw.attr_string(root, "format", kAxfLibraryFormat, "/");
    rw.attr_int(root, "format_version", kAxfFormatVersion, "/");
    rw.attr_int(root, "paint_count", static_cast<std::int64_t>(paints.size()), "/");
    w.attr_string(root, kContentSha256, digest.sha256_hex(), "/");
    Handle group = w.create_group(root, "paints", "/paints");
    for (const auto& p : paints) {
      const std::string gp = "/paints/" + p.name;
      Handle g = w.create_group(group.get(), p.name, gp);
      write_paint(g.get(), gp, p, w);
    }
  });
  const auto problems = check_image(image, path.string(), true);
  if (!problems.empty()) throw_problems(path.string(), problems);
  write_file_atomic(path, image);
}

std::vector<AxfPaint> read_axf_library_file(const fs::path& path) {
  std::vector<std::string> problems;
  auto in = open_file(path, Problems{&problems}, true);
  if (!in) throw_problems(path.string(), problems);
  const Problems p{&problems, &*in};
  Handle root = open_root(in->get(), p);
  if (!root) throw_problems(path.string(), problems);
  auto fmt_attr = h5::read_attr_string(root.get(), "format", "/", p);
  if (fmt_attr && *fmt_attr != kAxfLibraryFormat)
    p.add(h5::attr_path("/", "format"), "'" + *fmt_attr + "' is not '" + kAxfLibraryFormat + "'");
  if (!problems.empty()) throw_problems(path.string(), problems);
  auto paints = read_library(root.get(), p, nullptr);
  if (!problems.empty()) throw_problems(path.string(), problems);
  return paints;
}

AxfValidation validate_axf_file(const fs::path& path) {
  AxfValidation v;
  auto in = open_file(path, Problems{&v.problems}, false);
  if (!in) return v;
  const Problems p{&v.problems, &*in};
  Handle root = open_root(in->get(), p);
  if (!root) return v;
  std::vector<std::string> ignore;
  auto fmt_attr = h5::read_attr_string(root.get(), "format", "/", Problems{&ignore, &*in});
  std::optional<std::int64_t> version;
  if (fmt_attr && *fmt_attr == kAxfLibraryFormat) {
    v.format = kAxfLibraryFormat;
    read_library(root.get(), p, &v.paints, &version);
  } else {
    v.format = kAxfFormat;
    AxfPaint paint = read_paint(root.get(), "/", p, &version);
    if (!paint.name.empty()) v.paints.push_back(paint.name);
  }
  v.format_version = static_cast<int>(version.value_or(0));
  return v;
}

std::string describe_axf(const AxfPaint& a) {
  std::string s = fmt::format("paint '{}' (model {}), values in {}\n", a.name, a.model, a.colour_space);
  if (a.carpaint) {
    const auto& c = *a.carpaint;
    s += fmt::format("  carpaint: clear-coat ior {:.4g}, diffuse {:.4g}, colour table {} x {} (scale {:.4g})\n", c.ior,
                     c.diffuse, c.chi.theta_h_samples, c.chi.theta_i_samples, c.chi.scale);
    const auto* sd = a.carpaint_stddev ? &*a.carpaint_stddev : nullptr;
    if (sd) s += fmt::format("    standard deviations: ior {:.2g}, diffuse {:.2g}\n", sd->ior, sd->diffuse);
    for (std::size_t k = 0; k < c.lobes.size(); ++k) {
      s += fmt::format("    lobe {}: coefficient {:.5g}  spread {:.5g}  F0 {:.5g}", k + 1, c.lobes[k].coefficient,
                       c.lobes[k].spread, c.lobes[k].f0);
      if (sd && k < sd->lobes.size())
        s += fmt::format("  (+- {:.2g}, {:.2g}, {:.2g})", sd->lobes[k].coefficient, sd->lobes[k].spread,
                         sd->lobes[k].f0);
      s += "\n";
    }
  }
  if (a.cook_torrance) {
    const auto& ct = *a.cook_torrance;
    const auto* sd = ct.stddev ? &*ct.stddev : nullptr;
    auto pm = [&](double v, double e) { return sd ? fmt::format("{:.5g} +- {:.2g}", v, e) : fmt::format("{:.5g}", v); };
    s += "  cook-torrance" + std::string(sd ? " (value +- one standard deviation)" : "") + ":\n";
    const brdf::Rgb kd_sd = sd ? sd->kd : brdf::Rgb::Zero();
    s += fmt::format("    kd  [{}, {}, {}]\n", pm(ct.params.kd[0], kd_sd[0]), pm(ct.params.kd[1], kd_sd[1]),
                     pm(ct.params.kd[2], kd_sd[2]));
    for (std::size_t k = 0; k < ct.params.lobes.size(); ++k) {
      const auto& l = ct.params.lobes[k];
      const brdf::CtLobe e = sd ? sd->lobes[k] : brdf::CtLobe{brdf::Rgb::Zero(), 0, 0};
      s += fmt::format("    lobe {}: ks [{}, {}, {}]  m {}  r {}\n", k + 1, pm(l.ks[0], e.ks[0]), pm(l.ks[1], e.ks[1]),
                       pm(l.ks[2], e.ks[2]), pm(l.m, e.m), pm(l.r, e.r));
    }
  }
  if (a.cosine_lobes && !a.cosine_lobes->exponents.empty()) {
    const auto& cl = *a.cosine_lobes;
    auto rgb = [](const brdf::Rgb& c) { return fmt::format("[{:.4g}, {:.4g}, {:.4g}]", c[0], c[1], c[2]); };
    s += fmt::format("  cosine lobes{}: {} exponent{} {:.5g} .. {:.5g}; kd {}\n",
                     a.model == "cosine-lobes" ? "" : " (an approximation of the paint)", cl.exponents.size(),
                     cl.exponents.size() == 1 ? "" : "s", cl.exponents.front(), cl.exponents.back(), rgb(cl.kd));
    for (std::size_t k = 0; k < std::min({cl.exponents.size(), cl.kg.size(), cl.kdd.size()}); ++k)
      s += fmt::format("    exponent {:.5g}: kg {}  kdd {}\n", cl.exponents[k], rgb(cl.kg[k]), rgb(cl.kdd[k]));
  }
  if (a.flakes)
    s += fmt::format("  flakes: density {:.4g}, roughness {:.4g}, lifetime {:.3g} deg, {} lobe(s)\n", a.flakes->density,
                     a.flakes->roughness, a.flakes->lifetime_deg, a.flakes->lobes.size());
  if (a.flake_stats) {
    const FlakeStats& f = *a.flake_stats;
    s += fmt::format("  measured flakes: sparkle area {:.3f} % of {} pixel observations, lifetime {:.2f} deg, {} slices "
                     "with glints\n",
                     100.0 * f.area(), f.pixels, f.lifetime_deg,
                     std::count_if(f.slices.begin(), f.slices.end(), [](const FlakeSlice& x) { return x.glints > 0; }));
    for (const InstrumentSparkle& is : f.instrument)
      if (is.measured())
        s += fmt::format("    {:.0f} deg: sparkle area {:.3f} %, intensity {:.2f}\n", is.illumination_deg,
                         is.area_percent, is.intensity);
  }
  if (a.flake_btf)
    s += fmt::format("  flake BTF: {} slices of {} x {} texels, {} x {} bins, max_thetaI {}\n", a.flake_btf->slices(),
                     a.flake_btf->texture_size, a.flake_btf->texture_size, a.flake_btf->num_theta_f,
                     a.flake_btf->num_theta_i, a.flake_btf->max_theta_i);
  if (a.fit_quality)
    s += fmt::format("  fit quality: log RMS {:.4f} over {} bins{}\n", a.fit_quality->log_rms,
                     a.fit_quality->bins_used, a.fit_quality->converged ? "" : " (did NOT converge)");
  const auto& pv = a.provenance;
  auto or_unknown = [](const std::string& x) { return x.empty() ? std::string("unknown") : x; };
  s += fmt::format("  sample {}, measured {}, rig {}\n", or_unknown(pv.sample_name), or_unknown(pv.measured_utc),
                   or_unknown(pv.rig_name));
  s += fmt::format("  exported {} by paintlab {} from {}\n", or_unknown(pv.exported_utc),
                   or_unknown(pv.software_version), or_unknown(pv.source));
  if (!pv.session_sha256.empty()) s += "  session sha256 " + pv.session_sha256 + "\n";
  for (const auto& [file, sum] : pv.calibration_sha256) s += fmt::format("  calibration {} sha256 {}\n", file, sum);
  return s;
}

}  // namespace paintlab::fit
