// The fit and colour sections (docs/reports.md).
#include <fmt/format.h>

#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/fitting/multiangle.h"
#include "report_parts.h"

namespace paintlab::report {
namespace fs = std::filesystem;
namespace {

std::string rgb_cell(const Json* v, const Json* sd) {
  if (!v || !v->is_array()) return "—";
  std::string s;
  for (std::size_t c = 0; c < v->size(); ++c) {
    if (c) s += "<br>";
    s += num_of(&(*v)[c], 5);
    if (sd && sd->is_array() && c < sd->size()) s += " ± " + num_of(&(*sd)[c], 2);
  }
  return s;
}

std::string scalar_cell(const Json* v, const Json* sd) {
  if (!v) return "—";
  return num_of(v, 5) + (sd && sd->is_number() ? " ± " + num_of(sd, 2) : std::string());
}

std::string parameters_part(const Json& fit) {
  const std::string model = text_of(at(fit, {"model"}), "");
  std::string s = fmt::format("<h3>Parameters ({})</h3>\n", esc(model));
  const Json* lobes = at(fit, {"lobes"});
  if (model == "cook-torrance" && lobes && lobes->is_array()) {
    Table t;
    t.id = "parameters";
    t.head = {"parameter", "value ± standard deviation (R, G, B)"};
    t.rows.push_back({"k<sub>d</sub> (1/sr)", with_id("fit-kd", rgb_cell(at(fit, {"kd"}), at(fit, {"stddev", "kd"})))});
    const Json* sd_lobes = at(fit, {"stddev", "lobes"});
    for (std::size_t k = 0; k < lobes->size(); ++k) {
      const Json& l = (*lobes)[k];
      const Json* sd = sd_lobes && sd_lobes->is_array() && k < sd_lobes->size() ? &(*sd_lobes)[k] : nullptr;
      const std::string n = std::to_string(k + 1);
      t.rows.push_back({"lobe " + n + " k<sub>s</sub>", with_id("fit-lobe" + n + "-ks", rgb_cell(at(l, {"ks"}), sd ? at(*sd, {"ks"}) : nullptr))});
      t.rows.push_back({"lobe " + n + " m (Beckmann)", with_id("fit-lobe" + n + "-m", scalar_cell(at(l, {"m"}), sd ? at(*sd, {"m"}) : nullptr))});
      t.rows.push_back({"lobe " + n + " r (Schlick F0)", with_id("fit-lobe" + n + "-r", scalar_cell(at(l, {"r"}), sd ? at(*sd, {"r"}) : nullptr))});
    }
    s += table_html(t);
  } else {
    Json params = fit;
    for (const char* k : {"input", "residual", "summary", "stddev", "name", "model"}) params.erase(k);
    s += "<pre id=\"parameters\">" + esc(params.dump(2)) + "</pre>\n";
    if (const Json* sd = at(fit, {"stddev"})) s += "<p>Standard deviations:</p><pre>" + esc(sd->dump(2)) + "</pre>\n";
  }
  return s;
}

std::string convergence_part(const Json& fit, Section& sec) {
  const Json* sum = at(fit, {"summary"});
  if (!sum) return "<p class=\"missing\">No solver summary in fit.json.</p>\n";
  const Json* conv = at(*sum, {"converged"});
  const bool ok = conv && conv->is_boolean() && conv->get<bool>();
  if (!ok) sec.failing.push_back("fit: did not converge (" + text_of(at(*sum, {"termination"})) + ")");
  std::string s = fmt::format(
      "<p class=\"verdict {}\" id=\"fit-converged\">{}: {} after {} iterations in {} s; cost {} → {}; "
      "χ²/dof {}; covariance {}.</p>\n",
      ok ? "pass" : "fail", ok ? "Converged" : "Did NOT converge", esc(text_of(at(*sum, {"termination"}))),
      text_of(at(*sum, {"iterations"})), num_of(at(*sum, {"time_s"}), 3), num_of(at(*sum, {"initial_cost"}), 6),
      num_of(at(*sum, {"final_cost"}), 6), num_of(at(*sum, {"chi2_per_dof"})),
      esc(text_of(at(*sum, {"covariance_message"}), "not computed")));
  if (const Json* starts = at(*sum, {"starts"}); starts && starts->is_array() && !starts->empty()) {
    Table t;
    t.head = {"start", "iterations", "initial cost", "final cost", "converged"};
    for (const Json& st : *starts)
      t.rows.push_back({esc(text_of(at(st, {"origin"}))), text_of(at(st, {"iterations"})),
                        num_of(at(st, {"initial_cost"}), 6), num_of(at(st, {"final_cost"}), 6),
                        text_of(at(st, {"converged"}))});
    s += "<details><summary>" + fmt::format("{} starts of the multi-start search", starts->size()) + "</summary>" +
         table_html(t) + "</details>\n";
  }
  return s;
}

std::string residual_part(const Json& fit) {
  const Json* res = at(fit, {"residual"});
  if (!res) return "<p class=\"missing\">No residuals in fit.json.</p>\n";
  std::string s = "<h3>Residuals against the noise floor</h3>\n";
  Table t;
  t.id = "residuals";
  t.head = {"region", "bins", "log-RMS", "noise floor", "log-RMS / floor"};
  const auto row = [&](const std::string& name, const Json& r, const std::string& id) {
    const double rms = number_or_nan(at(r, {"log_rms"}));
    const double floor = number_or_nan(at(r, {"noise_floor"}));
    t.rows.push_back({name, text_of(at(r, {"bins"})), with_id(id, num(rms)), num(floor), num(rms / floor, 3)});
  };
  if (const Json* regions = at(*res, {"regions"}); regions && regions->is_object())
    for (const auto& [name, r] : regions->items()) row(esc(name), r, "fit-log-rms-" + name);
  t.rows.push_back({"<b>all</b>", text_of(at(*res, {"bins_used"})),
                    with_id("fit-log-rms", num_of(at(*res, {"log_rms"}))), num_of(at(*res, {"noise_floor_log_rms"})),
                    num(number_or_nan(at(*res, {"log_rms"})) / number_or_nan(at(*res, {"noise_floor_log_rms"})), 3)});
  s += table_html(t);
  s += fmt::format("<p class=\"note\">log-RMS: root mean square of log(model/measured) over the used bins and "
                   "channels; noise floor: what the measurement's own noise alone would give ({}). A ratio near 1 "
                   "means the model explains the data to their noise.</p>\n",
                   esc(text_of(at(*res, {"noise_source"}))));
  const Json* curves = at(*res, {"curves"});
  if (curves && curves->is_array() && !curves->empty()) {
    static constexpr const char* kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"};
    Plot p = make_plot("Measured (dots) and fitted (lines) along θh", "θh (deg)", "BRDF (1/sr)", 720, 440);
    p.log_y = true;
    for (std::size_t k = 0; k < curves->size(); ++k) {
      const Json& c = (*curves)[k];
      const char* colour = kColours[k % 6];
      Series measured = series(fmt::format("θd {}°", num_of(at(c, {"theta_d_deg"}))), "points", colour, 1.4);
      Series model = series("", "lines", colour, 1.8);
      const Json* th = at(c, {"theta_h_deg"});
      const Json* me = at(c, {"measured"});
      const Json* mo = at(c, {"model"});
      for (std::size_t i = 0; th && me && mo && i < th->size() && i < me->size() && i < mo->size(); ++i) {
        measured.x.push_back(number_or_nan(&(*th)[i]));
        measured.y.push_back(number_or_nan(&(*me)[i]));
        model.x.push_back(number_or_nan(&(*th)[i]));
        model.y.push_back(number_or_nan(&(*mo)[i]));
      }
      p.series.push_back(std::move(measured));
      p.series.push_back(std::move(model));
    }
    s += plot_figure(p, "Günther et al. 2005, Figure 5: the fit points within ±2.5° of each θd, grouped by θh bin, "
                        "averaged over φd and the colour channels; the model at the same points.");
  } else {
    s += "<p class=\"missing\">No measured-against-fitted curves: this fit.json predates them (paintlab 0.1 fits "
         "from before the report) or its bins cover none of the θd slices.</p>\n";
  }
  return s;
}

// The fit's samples in the (theta_h, theta_d) plane (fit.json residual.coverage), on MERL's
// bins: theta_h on its square-root axis, as the table stores it.
std::string coverage_part(const Json& fit) {
  const Json* cells = at(fit, {"residual", "coverage", "cells"});
  if (!cells || !cells->is_array() || cells->empty()) return {};
  std::vector<double> grid(90 * 90, std::nan(""));
  long covered = 0;
  for (const Json& c : *cells) {
    if (!c.is_array() || c.size() != 3) continue;
    const int i = c[0].get<int>(), j = c[1].get<int>();
    if (i < 0 || i >= 90 || j < 0 || j >= 90) continue;
    grid[static_cast<std::size_t>(i * 90 + j)] = std::log10(std::max(1.0, c[2].get<double>()));
    ++covered;
  }
  Series map = series("", "image", "", 1.0);
  for (int i = 0; i < 90; ++i)
    for (int j = 0; j < 90; ++j) {
      map.x.push_back(i);
      map.y.push_back(j);
      map.z.push_back(grid[static_cast<std::size_t>(i * 90 + j)]);
    }
  Plot p = make_plot("Half-vector coverage: samples per (θh, θd) bin", "θh (deg; MERL bins, square-root axis)", "θd (deg)", 640, 520);
  p.series = {map};
  std::string tics = "xtics (";
  for (double d : {0.0, 1.0, 4.0, 10.0, 20.0, 40.0, 60.0, 90.0})
    tics += fmt::format("{}\"{}\" {:.3f}", d > 0 ? ", " : "", d, std::sqrt(d / 90.0) * 90.0 - 0.5);
  p.settings = {tics + ")", "xrange [-0.5:89.5]", "yrange [-0.5:89.5]", "cblabel \"log10 samples\"",
                "palette defined (0 \"#f7fbff\", 1 \"#6baed6\", 2 \"#08306b\")", "size ratio 1"};
  return plot_figure(p, fmt::format("Where the fit has measured data: {} of the 8100 (θh, θd) bins (summed over φd; "
                                    "white: none). The sweep's light circle fixes which θd each θh is seen at.",
                                    covered));
}

std::string extraction_part(const Json& fit) {
  const Json* ex = at(fit, {"input", "extraction"});
  if (!ex || !ex->is_object()) return {};
  Table t;
  t.id = "extraction";
  t.head = {"pixels", "count"};
  for (const auto& [k, v] : ex->items()) t.rows.push_back({esc(k), with_id("extraction-" + k, text_of(&v))});
  std::string s = "<h3>Samples</h3>\n" + table_html(t);
  s += "<p class=\"note\">sphere_pixels: sphere pixels over all images; samples: those that became BRDF samples; "
       "invalid: saturated, too dark or not valid in the HDR merge; grazing: too close to the silhouette.</p>\n";
  if (const Json* cov = at(fit, {"input", "coverage"}); cov && cov->is_object()) {
    Table c;
    c.head = {"region", "coverage"};
    for (const auto& [k, v] : cov->items()) c.rows.push_back({esc(k), esc(v.dump())});
    s += "<details><summary>half-vector coverage per region</summary>" + table_html(c) + "</details>\n";
  }
  return s;
}

}  // namespace

Section fit_section(const fs::path& fit_json, const std::vector<fs::path>& images, const SectionOptions& o) {
  Section sec{"fit", "Fit", {}, {}, {}};
  if (!fs::exists(fit_json)) {
    sec.html = "<p class=\"missing\">No fit: " + esc(fit_json.string()) + " not found. Run <code>paintlab fit</code>.</p>\n";
    sec.missing.push_back("fit: fit.json not found");
    return sec;
  }
  const Json fit = read_json_file(fit_json);
  if (!fit.is_object() || !at(fit, {"model"}))
    throw DataError(fit_json.string() + ": not a fit (no key 'model')");
  std::string& s = sec.html;
  // Several sessions fitted together: each one's folder.
  std::string source = "<code>" + esc(text_of(at(fit, {"input", "path"}), "")) + "</code>";
  if (const Json* list = at(fit, {"input", "sessions"}); list && list->is_array() && !list->empty()) {
    source.clear();
    for (const Json& one : *list)
      source += (source.empty() ? "" : ", ") + std::string("<code>") + esc(text_of(at(one, {"path"}), "")) + "</code>";
    source = fmt::format("{} together: {}", list->size(), source);
  }
  s += fmt::format("<p>Paint <b>{}</b>, model {}, from {} {}.</p>\n", esc(text_of(at(fit, {"name"}))),
                   esc(text_of(at(fit, {"model"}))), esc(text_of(at(fit, {"input", "kind"}), "input")), source);
  s += convergence_part(fit, sec);
  s += parameters_part(fit);
  s += residual_part(fit);
  s += coverage_part(fit);
  s += extraction_part(fit);
  std::string pictures;
  for (const fs::path& img : images) {
    const std::string tag = png_file_img(img, img.filename().string(), o.max_image_px);
    if (tag.empty()) {
      sec.missing.push_back("fit: picture " + img.filename().string() + " not readable");
      continue;
    }
    pictures += fmt::format("<figure>{}<figcaption>{}</figcaption></figure>\n", tag, esc(img.filename().string()));
  }
  if (!pictures.empty()) s += "<h3>Pictures</h3>\n" + pictures;
  return sec;
}

Section colour_section(const fs::path& fit_json, const Json* summary, const SectionOptions&) {
  Section sec{"colour", "Colour", {}, {}, {}};
  std::string& s = sec.html;
  const Json* demo = summary ? at(*summary, {"colour"}) : nullptr;
  if (demo && at(*demo, {"geometries"})) {
    s += "<p>CIELAB (D65, 2° observer) at the multi-angle geometries: the simulator's paint (truth), the fitted "
         "model and the measured samples nearest each geometry.</p>\n";
    Table t;
    t.id = "colour";
    t.head = {"geometry", "truth L* a* b*", "fit L* a* b*", "measured L* a* b*", "dE00 fit", "dE00 measured"};
    const auto lab = [](const Json* c) {
      if (!c || !c->is_object()) return std::string("—");
      return fmt::format("{} {} {}", num_of(at(*c, {"L"})), num_of(at(*c, {"a"}), 3), num_of(at(*c, {"b"}), 3));
    };
    for (const Json& g : *at(*demo, {"geometries"})) {
      const std::string name = text_of(at(g, {"name"}));
      t.rows.push_back({esc(name), lab(at(g, {"truth"})), lab(at(g, {"fit"})), lab(at(g, {"measured"})),
                        with_id("colour-fit-de00-" + name, num_of(at(g, {"fit_de00"}), 3)),
                        num_of(at(g, {"measured_de00"}), 3)});
    }
    s += table_html(t);
    s += fmt::format("<p>Flop index: truth {}, fit {}.</p>\n", num_of(at(*demo, {"flop_index_truth"})),
                     num_of(at(*demo, {"flop_index_fit"})));
    return sec;
  }
  if (fit_json.empty() || !fs::exists(fit_json)) {
    s = "<p class=\"missing\">No colour: there is no fit to evaluate.</p>\n";
    return sec;
  }
  fit::MultiAngleColour c;
  try {
    c = fit::paint_colour(fit_json, fit::geometry_set(fit::kDefaultGeometrySet));
  } catch (const DataError& e) {
    s = "<p class=\"missing\">No CIELAB: " + esc(e.what()) + "</p>\n";
    sec.missing.push_back(std::string("colour: ") + e.what());
    return sec;
  }
  Table t;
  t.id = "colour";
  t.head = {"geometry", "model L*", "a*", "b*"};
  for (const fit::AngleColour& a : c.model)
    t.rows.push_back({esc(a.geometry.name), with_id("colour-L-" + a.geometry.name, num(a.lab.L)), num(a.lab.a, 3),
                      num(a.lab.b, 3)});
  s += "<p>CIELAB (D65, 2° observer) of the fitted model at the five in-plane geometries (docs/colour.md).</p>\n";
  s += table_html(t);
  s += fmt::format("<p>Flop index {}.</p>\n", c.flop ? num(*c.flop) : std::string("—"));
  return sec;
}

}  // namespace paintlab::report
