// The report's sparkle section: the flakes measured from the session (flakes.json, docs/sparkle.md).
#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "paintlab/core/colour.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/flakes.h"
#include "report_parts.h"

namespace paintlab::report {

namespace {

// A swatch of a cluster's chromaticity (at L* 70 for display) with its probability.
std::string swatch(const fit::FlakeCluster& c) {
  const auto unit = fit::flake_chromaticities({c});
  if (unit.empty()) return "";
  const colour::Lab shown{70.0, unit[0].mean.a, unit[0].mean.b};
  const colour::Rgb rgb = colour::xyz_to_srgb(colour::lab_to_xyz(shown, colour::d65()));
  auto encode = [](double v) {
    v = std::clamp(v, 0.0, 1.0);
    return static_cast<int>(std::lround(255.0 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055)));
  };
  return fmt::format("<span class=\"swatch\" title=\"{:.0f} %: a* {:.1f}, b* {:.1f} at equal lightness\" "
                     "style=\"display:inline-block;width:14px;height:14px;margin-right:2px;border:1px solid #888;"
                     "background:rgb({},{},{})\"></span>",
                     100 * c.probability, unit[0].mean.a, unit[0].mean.b, encode(rgb[0]), encode(rgb[1]),
                     encode(rgb[2]));
}

}  // namespace

Section sparkle_section(const std::filesystem::path& flakes_json, const SectionOptions&) {
  Section s{"sparkle", "Sparkle", "", {}, {}};
  fit::FlakeStats f;
  try {
    f = fit::flakes_from_json(read_json_file(flakes_json), flakes_json.string());
  } catch (const Error& e) {
    s.html = "<p class=\"missing\">" + esc(e.what()) + "</p>\n";
    s.missing.push_back("sparkle: " + std::string(e.what()));
    return s;
  }
  const double bin = 90.0 / f.options.num_theta_f, bin_i = 90.0 / f.options.num_theta_i;
  std::string h = "<p>The flakes as <code>paintlab flakes</code> measured them: every sphere pixel of every light "
                  "position against the smooth fit; a glint is a pixel above it by " +
                  num(f.options.threshold_sigma, 3) + " noise standard deviations and " +
                  num(100 * f.options.threshold_ratio, 3) +
                  " % of the model. Slices of the directions refracted by the clear coat (index " +
                  num(f.options.ior, 3) + "), " + num(bin, 3) + "° wide (docs/sparkle.md).</p>\n";
  if (f.empty()) h += "<p id=\"sparkle-empty\">No glint: a paint without sparkle; its flake model is empty.</p>\n";
  Table t{"sparkle-summary", {"images", "pixel observations", "glints", "sparkle area", "glint runs", "lifetime",
                              "half-vector step"}, {}, {}};
  t.rows.push_back({std::to_string(f.images), std::to_string(f.pixels), std::to_string(f.glints),
                    with_id("sparkle-area", num(100 * f.area(), 4) + " %"), std::to_string(f.runs),
                    with_id("sparkle-lifetime", num(f.lifetime_deg, 3) + "°"), num(f.step_deg, 3) + "°"});
  h += table_html(t);
  Table inst{"sparkle-instrument", {"illumination", "viewing", "pixel observations", "sparkle area", "sparkle intensity"}, {}, {}};
  for (const fit::InstrumentSparkle& is : f.instrument)
    inst.rows.push_back({num(is.illumination_deg, 3) + "°", "0° (along the normal)", std::to_string(is.pixels),
                         is.measured() ? with_id(fmt::format("sparkle-area-{:.0f}", is.illumination_deg),
                                                 num(is.area_percent, 3) + " %")
                                       : "not measured",
                         is.glints ? num(is.intensity, 3) : "—"});
  h += "<h3>Instrument-style numbers</h3>\n<p>Directional light at 15, 45 and 75° viewed along the normal (within " +
       num(f.options.instrument_tolerance_deg, 3) +
       "°): the share of observations that glint and the glints' mean contrast. Instruments' own definitions are "
       "unpublished: compare paints measured on this rig, instruments only by rank.</p>\n" + table_html(inst);

  // Area and intensity against theta_I, one line per theta_F bin with glints.
  std::map<int, std::vector<const fit::FlakeSlice*>> by_f;
  for (const fit::FlakeSlice& sl : f.slices)
    if (sl.glints > 0) by_f[sl.theta_f].push_back(&sl);
  if (!by_f.empty()) {
    Plot area = make_plot("Sparkle area per slice", "θI (deg, bin centre)", "glinting share of the pixels (%)", 640, 380);
    Plot intensity = make_plot("Glint intensity per slice", "θI (deg, bin centre)", "mean contrast (excess / model)", 640, 380);
    for (const auto& [tf, list] : by_f) {
      const std::string title = fmt::format("θF {:.3g}–{:.3g}°", tf * bin, (tf + 1) * bin);
      Series a = series(title, "linespoints", "", 1.6), b = series(title, "linespoints", "", 1.6);
      for (const fit::FlakeSlice* sl : list) {
        const double x = (sl->theta_i + 0.5) * bin_i;
        a.x.push_back(x);
        a.y.push_back(100 * sl->area());
        b.x.push_back(x);
        b.y.push_back(sl->intensity_mean);
      }
      area.series.push_back(std::move(a));
      intensity.series.push_back(std::move(b));
    }
    h += plot_figure(area, "The share of pixel observations that glint, per slice: how much of the lit surface "
                           "sparkles at that geometry.");
    h += plot_figure(intensity, "The glints' mean contrast per slice.");
  }
  // The busiest slices with their colours.
  std::vector<const fit::FlakeSlice*> busy;
  for (const fit::FlakeSlice& sl : f.slices)
    if (sl.glints > 0) busy.push_back(&sl);
  std::sort(busy.begin(), busy.end(), [](const auto* a, const auto* b) { return a->glints > b->glints; });
  if (!busy.empty()) {
    Table st{"sparkle-slices", {"θF", "θI", "pixels", "glints", "area", "intensity (mean, median)", "lifetime",
                                "colour clusters (most likely first)"}, {}, {}};
    for (std::size_t k = 0; k < std::min<std::size_t>(12, busy.size()); ++k) {
      const fit::FlakeSlice& sl = *busy[k];
      std::string colours;
      for (std::size_t c = 0; c < std::min<std::size_t>(10, sl.clusters.size()); ++c) colours += swatch(sl.clusters[c]);
      colours += fmt::format(" {} clusters", sl.clusters.size());
      st.rows.push_back({fmt::format("{:.3g}–{:.3g}°", sl.theta_f * bin, (sl.theta_f + 1) * bin),
                         fmt::format("{:.3g}–{:.3g}°", sl.theta_i * bin_i, (sl.theta_i + 1) * bin_i),
                         std::to_string(sl.pixels), std::to_string(sl.glints), num(100 * sl.area(), 3) + " %",
                         num(sl.intensity_mean, 3) + ", " + num(sl.intensity_quantiles[2], 3),
                         sl.runs ? num(sl.lifetime_deg, 3) + "°" : "—", colours});
    }
    h += "<h3>Slices with the most glints</h3>\n<p>Colours: each cluster's chromaticity shown at equal lightness "
         "(its lightness is the glint's intensity).</p>\n" + table_html(st);
  }
  s.html = h;
  return s;
}

}  // namespace paintlab::report
