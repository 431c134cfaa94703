// The calibration section: one table of every stage's figures, then each stage's evidence
// (docs/reports.md "Calibration").
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "paintlab/core/colour.h"
#include "paintlab/core/image_io.h"
#include "report_parts.h"

namespace paintlab::report {
namespace fs = std::filesystem;
namespace {

struct StageFile {
  const char* file;
  const char* stage;
  const char* command;  // what makes it
};
constexpr StageFile kStages[] = {
    {"camera.json", "intrinsics", "paintlab calibrate intrinsics"},
    {"response.json", "response", "paintlab calibrate response"},
    {"dark.json", "dark", "paintlab calibrate dark"},
    {"flat.json", "flat", "paintlab calibrate flat"},
    {"sphere.json", "sphere", "paintlab calibrate sphere"},
    {"light.json", "light", "paintlab calibrate light"},
    {"scale.json", "scale", "paintlab calibrate scale"},
    {"colour.json", "colour", "paintlab calibrate colour"},
};

// "value ± std" with both to the same number of digits.
std::string plus_minus(const Json* v, const Json* s) {
  if (!v) return "—";
  if (!s || !s->is_number()) return num_of(v, 6);
  return num_of(v, 6) + " ± " + num_of(s, 2);
}

// The stage's headline figures for the overview table.
std::string stage_figures(const std::string& stage, const Json& j) {
  if (stage == "intrinsics")
    return fmt::format("reprojection RMS {} px, worst {} px; {} views used, {} dropped",
                       num_of(at(j, {"rms_px"})), num_of(at(j, {"worst_px"})),
                       text_of(at(j, {"views_used"})), text_of(at(j, {"views_dropped"}), "0"));
  if (stage == "response") {
    return fmt::format("linearity RMS {} (relative), non-linearity {}, method {}",
                       num_of(at(j, {"fit", "linearity_rms_rel"})), numbers_text(at(j, {"fit", "nonlinearity_rel"})),
                       text_of(at(j, {"method"})));
  }
  if (stage == "dark")
    return fmt::format("bias {} DN, dark current {} DN/s, read noise {} DN, {} hot pixels",
                       num_of(at(j, {"mean_bias_dn"})), num_of(at(j, {"mean_rate_dn_per_s"})),
                       num_of(at(j, {"read_noise_dn"})), text_of(at(j, {"hot_count"})));
  if (stage == "flat")
    return fmt::format("PRNU {}, corner/centre {}, {} frames", num_of(at(j, {"prnu_rel"})),
                       num_of(at(j, {"corner_ratio"})), text_of(at(j, {"frame_count"})));
  if (stage == "sphere")
    return fmt::format("edge RMS {} px, worst {} px, {} of {} edges used, radius {} m", num_of(at(j, {"rms_px"})),
                       num_of(at(j, {"max_px"})), text_of(at(j, {"edges_used"})), text_of(at(j, {"edges_total"})),
                       num_of(at(j, {"radius_m"})));
  if (stage == "light")
    return fmt::format("azimuth RMS {} deg, worst {} deg, {} highlights used", num_of(at(j, {"rms_deg"})),
                       num_of(at(j, {"max_deg"})), text_of(at(j, {"used"})));
  if (stage == "scale")
    return fmt::format("scale {} (spread {}, uncertainty {})", num_of(at(j, {"scale"})),
                       num_of(at(j, {"spread_rel"})), num_of(at(j, {"uncertainty_rel"})));
  if (stage == "colour")
    return fmt::format("chart dE00 mean {}, max {} ({}), model {}", num_of(at(j, {"mean_de00"})),
                       num_of(at(j, {"max_de00"})), text_of(at(j, {"worst_patch"})), text_of(at(j, {"model"})));
  return {};
}

// A histogram of `values` as boxes.
Series histogram(const std::vector<double>& values, int bins, double& width) {
  Series h = series("", "boxes", "#7f8c8d", 1.0);
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  width = std::max((*hi - *lo) / bins, 1e-9);
  std::vector<double> counts(static_cast<std::size_t>(bins), 0.0);
  for (double v : values)
    counts[static_cast<std::size_t>(std::clamp(static_cast<int>((v - *lo) / width), 0, bins - 1))] += 1;
  for (int b = 0; b < bins; ++b) {
    h.x.push_back(*lo + (b + 0.5) * width);
    h.y.push_back(counts[static_cast<std::size_t>(b)]);
  }
  return h;
}

// 1, 2 or 5 times a power of ten, at most x.
double nice_below(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= x) return m * p;
  return p;
}

// Every corner's residual vector (camera.json views[].residuals_px, from paintlab 0.1+g6938964
// on) on the image, magnified, and the histogram of their lengths with RMS, worst and the
// corners beyond 3 x RMS.
std::string corner_residuals_part(const Json& cam, const Json& views) {
  Series arrows = series("", "vectors", "#c0392b", 1.0);
  Series dropped_arrows = series("", "vectors", "#999999", 1.0);
  std::vector<double> lengths;
  for (const Json& v : views) {
    const Json* c = at(v, {"corners_px"});
    const Json* r = at(v, {"residuals_px"});
    if (!c || !r || !c->is_array() || !r->is_array() || c->size() != r->size()) continue;
    const Json* used = at(v, {"used"});
    const bool in_fit = used && used->is_boolean() && used->get<bool>();
    Series& target = in_fit ? arrows : dropped_arrows;
    for (std::size_t i = 0; i < c->size(); ++i) {
      const double dx = number_or_nan(&(*r)[i][0]), dy = number_or_nan(&(*r)[i][1]);
      target.x.push_back(number_or_nan(&(*c)[i][0]));
      target.y.push_back(number_or_nan(&(*c)[i][1]));
      target.dx.push_back(dx);
      target.dy.push_back(dy);
      if (in_fit) lengths.push_back(std::hypot(dx, dy));
    }
  }
  if (lengths.size() < 4) {
    return "<p class=\"note\">camera.json holds no per-corner residuals (written by paintlab before the report); "
           "per-view figures only.</p>\n";
  }
  double ss = 0, worst = 0;
  for (double l : lengths) {
    ss += l * l;
    worst = std::max(worst, l);
  }
  const double rms = std::sqrt(ss / static_cast<double>(lengths.size()));
  const long beyond = std::count_if(lengths.begin(), lengths.end(), [&](double l) { return l > 3.0 * rms; });
  const Json* size = at(cam, {"image_size"});
  const double w = size && size->is_array() && size->size() == 2 ? number_or_nan(&(*size)[0]) : 0.0;
  const double h = size && size->is_array() && size->size() == 2 ? number_or_nan(&(*size)[1]) : 0.0;
  // Magnified so that an RMS residual is 2 % of the image width.
  const double scale = nice_below(0.02 * (w > 0 ? w : 1000.0) / std::max(rms, 1e-9));
  for (Series* s : {&arrows, &dropped_arrows})
    for (std::size_t i = 0; i < s->dx.size(); ++i) {
      s->dx[i] *= scale;
      s->dy[i] *= scale;
    }
  Plot p = make_plot("Corner residuals on the image", "x (px)", "y (px)", 720, w > 0 && h > 0 ? static_cast<int>(std::clamp(720.0 * h / w, 300.0, 720.0)) + 40 : 560);
  p.series = {arrows};
  if (!dropped_arrows.x.empty()) p.series.push_back(dropped_arrows);
  if (w > 0 && h > 0) p.settings = {fmt::format("xrange [0:{}]", w), fmt::format("yrange [{}:0]", h), "size ratio -1"};
  std::string s = plot_figure(
      p, fmt::format("Each corner of every view: detected minus projected by the final camera, magnified {}x (red: "
                     "views in the fit; grey: dropped views). A pattern (a swirl, arrows growing to the corners) "
                     "means a distortion the model misses; random directions are noise.",
                     num(scale)));
  double width = 0;
  Series hist = histogram(lengths, 30, width);
  hist.title = "corners";
  Plot ph = make_plot("Histogram of the corner residuals", "residual (px)", "corners", 560, 320);
  ph.series = {hist};
  ph.settings = {fmt::format("boxwidth {:.9g}", width * 0.9), "yrange [0:*]", "xrange [0:*]"};
  s += plot_figure(ph, fmt::format("{} corners of the views in the fit: RMS <span id=\"corner-rms-px\">{}</span> px, "
                                   "worst {} px, {} beyond 3 x RMS.",
                                   lengths.size(), num(rms), num(worst), beyond));
  return s;
}

// What each stage left out as outliers or unusable (its own words for them).
std::string left_out(const std::string& stage, const Json& j) {
  const auto count_false = [&](const char* list, const char* flag) {
    const Json* a = at(j, {list});
    long n = 0;
    if (a && a->is_array())
      for (const Json& e : *a) {
        const Json* f = at(e, {flag});
        n += !(f && f->is_boolean() && f->get<bool>());
      }
    return n;
  };
  if (stage == "intrinsics") return fmt::format("{} views", text_of(at(j, {"views_dropped"}), "0"));
  if (stage == "sphere") {
    const double total = number_or_nan(at(j, {"edges_total"})), used = number_or_nan(at(j, {"edges_used"}));
    return std::isfinite(total - used) ? fmt::format("{} edges", total - used) : "—";
  }
  if (stage == "light") return fmt::format("{} highlights", count_false("highlights", "used"));
  if (stage == "scale") return fmt::format("{} saturated pixels", text_of(at(j, {"saturated"}), "0"));
  if (stage == "colour") return fmt::format("{} patches", count_false("patches", "used"));
  if (stage == "dark") return fmt::format("{} hot pixels", text_of(at(j, {"hot_count"}), "0"));
  return "—";
}

std::string intrinsics_part(const Json& cam) {
  std::string s = "<h3>Camera intrinsics (camera.json)</h3>\n";
  Table t;
  t.id = "intrinsics";
  t.head = {"parameter", "value ± standard deviation"};
  const Json* K = at(cam, {"K"});
  auto k = [&](int r, int c) -> const Json* {
    return K && K->is_array() && K->size() == 3 && (*K)[r].is_array() && (*K)[r].size() == 3 ? &(*K)[r][c] : nullptr;
  };
  t.rows.push_back({"f<sub>x</sub> (px)", with_id("camera-fx", plus_minus(k(0, 0), at(cam, {"std", "fx"})))});
  t.rows.push_back({"f<sub>y</sub> (px)", plus_minus(k(1, 1), at(cam, {"std", "fy"}))});
  t.rows.push_back({"c<sub>x</sub> (px)", plus_minus(k(0, 2), at(cam, {"std", "cx"}))});
  t.rows.push_back({"c<sub>y</sub> (px)", plus_minus(k(1, 2), at(cam, {"std", "cy"}))});
  static constexpr const char* kDist[] = {"k1", "k2", "p1", "p2", "k3"};
  const Json* dist = at(cam, {"dist"});
  const Json* dist_std = at(cam, {"std", "dist"});
  for (std::size_t i = 0; dist && dist->is_array() && i < dist->size() && i < 5; ++i) {
    const Json* sd = dist_std && dist_std->is_array() && i < dist_std->size() ? &(*dist_std)[i] : nullptr;
    const Json* fixed = at(cam, {"k3", "fixed"});
    if (i == 4 && fixed && fixed->is_boolean() && fixed->get<bool>())
      t.rows.push_back({kDist[i], num_of(&(*dist)[i]) + " (fixed)"});
    else
      t.rows.push_back({kDist[i], plus_minus(&(*dist)[i], sd)});
  }
  t.rows.push_back({"reprojection RMS (px)", with_id("camera-rms-px", num_of(at(cam, {"rms_px"})))});
  t.rows.push_back({"worst corner (px)", num_of(at(cam, {"worst_px"}))});
  t.rows.push_back({"views used / dropped",
                    text_of(at(cam, {"views_used"})) + " / " + text_of(at(cam, {"views_dropped"}), "0")});
  t.rows.push_back({"image size", text_of(at(cam, {"image_size"}))});
  s += table_html(t);
  if (const Json* note = at(cam, {"k3", "note"}))
    s += "<p class=\"note\"><b>k3:</b> " + esc(text_of(note)) + "</p>\n";
  // Per view: RMS and worst corner.
  const Json* views = at(cam, {"views"});
  if (views && views->is_array() && !views->empty()) {
    Series rms = series("RMS", "boxes", "#4a7fb5", 1.0);
    Series worst = series("worst corner", "points", "#c0392b", 2.0);
    std::vector<std::string> dropped;
    for (std::size_t i = 0; i < views->size(); ++i) {
      const Json& v = (*views)[i];
      rms.x.push_back(static_cast<double>(i));
      rms.y.push_back(number_or_nan(at(v, {"rms_px"})));
      worst.x.push_back(static_cast<double>(i));
      worst.y.push_back(number_or_nan(at(v, {"max_px"})));
      if (const Json* used = at(v, {"used"}); used && used->is_boolean() && !used->get<bool>())
        dropped.push_back(text_of(at(v, {"name"})));
    }
    Plot p = make_plot("Reprojection residual per view", "view", "residual (px)");
    p.series = {rms, worst};
    p.settings = {"boxwidth 0.7", "yrange [0:*]", fmt::format("xrange [-1:{}]", views->size())};
    s += plot_figure(p, fmt::format("Per view the RMS of the corner residuals (bars) and the worst corner (dots). "
                                    "Overall RMS {} px. {}",
                                    num_of(at(cam, {"rms_px"})),
                                    dropped.empty() ? std::string("No view was dropped.")
                                                    : "Dropped: " + esc(fmt::format("{}", fmt::join(dropped, ", ")))));
    s += corner_residuals_part(cam, *views);
  }
  return s;
}

std::string response_part(const Json& r) {
  std::string s = "<h3>Radiometric response (response.json)</h3>\n";
  const Json* knots = at(r, {"knots_dn"});
  const Json* linear = at(r, {"linear"});
  if (knots && linear && knots->is_array() && linear->is_array()) {
    Plot p = make_plot("Response curve", "raw value above dark (DN)", "linear value g(u)");
    static constexpr const char* kColours[] = {"#c0392b", "#27ae60", "#2e86c1"};
    static constexpr const char* kNames[] = {"R", "G", "B"};
    const bool mono = linear->size() == 1;
    for (std::size_t c = 0; c < linear->size() && c < 3; ++c) {
      const Json& curve = (*linear)[c];
      if (!curve.is_array()) continue;
      Series d = series(mono ? "g(u)" : kNames[c], "lines", mono ? "#333333" : kColours[c], 2.0);
      for (std::size_t i = 0; i < knots->size() && i < curve.size(); ++i) {
        d.x.push_back(number_or_nan(&(*knots)[i]));
        d.y.push_back(number_or_nan(&curve[i]));
      }
      p.series.push_back(std::move(d));
    }
    if (!p.series.empty())
      s += plot_figure(p, "The recovered response per channel: the linear value a raw reading stands for.");
    // The data about the curve: the scatter of the samples' exposure-normalised values at each
    // knot (response.json residual_std), relative to the curve there.
    const Json* scatter = at(r, {"residual_std"});
    if (scatter && scatter->is_array()) {
      Plot q = make_plot("Scatter of the data about the curve", "raw value above dark (DN)", "residual standard deviation / g(u)", 640, 320);
      q.log_y = true;
      for (std::size_t c = 0; c < scatter->size() && c < linear->size() && c < 3; ++c) {
        const Json& sd = (*scatter)[c];
        const Json& curve = (*linear)[c];
        if (!sd.is_array() || !curve.is_array()) continue;
        Series d = series(mono ? "samples" : kNames[c], "points", mono ? "#333333" : kColours[c], 1.0);
        for (std::size_t i = 0; i < knots->size() && i < sd.size() && i < curve.size(); ++i) {
          const double g = number_or_nan(&curve[i]);
          d.x.push_back(number_or_nan(&(*knots)[i]));
          d.y.push_back(g > 0 ? number_or_nan(&sd[i]) / g : std::nan(""));
        }
        q.series.push_back(std::move(d));
      }
      if (!q.series.empty())
        s += plot_figure(q, "What the measured samples say about the curve: at each knot the standard deviation of "
                            "the samples' exposure-normalised values, relative to the curve (shot and read noise "
                            "dominate at low values; a bump is where the curve misfits).");
    }
  }
  Table t;
  t.id = "response";
  t.head = {"figure", "value", "meaning"};
  t.rows.push_back({"linearity RMS (relative)", with_id("response-linearity-rms", num_of(at(r, {"fit", "linearity_rms_rel"}))),
                    "scatter of exposure-normalised values about the curve"});
  t.rows.push_back({"linearity error (relative)", num_of(at(r, {"fit", "linearity_error_rel"})),
                    "worst exposure-ratio error"});
  t.rows.push_back({"non-linearity per channel", esc(numbers_text(at(r, {"fit", "nonlinearity_rel"}))),
                    "largest departure of g from a straight line"});
  t.rows.push_back({"monotonicity violation per channel", esc(numbers_text(at(r, {"fit", "monotonic_violation_rel"}))),
                    "0 when the curve never decreases"});
  t.rows.push_back({"samples used", text_of(at(r, {"fit", "samples_used"})), ""});
  t.rows.push_back({"saturation (DN)", num_of(at(r, {"saturation_dn"})), "values above are not used"});
  s += table_html(t);
  return s;
}

// A map of an EXR calibration file as a false-colour picture, with its hot pixels circled.
std::string map_part(const fs::path& exr, const char* prefer, const std::string& what, int max_px) {
  if (!fs::exists(exr)) return "<p class=\"missing\">" + esc(exr.filename().string()) + " not found.</p>\n";
  const ExrImage img = read_exr(exr);
  const ImageF* plane = nullptr;
  for (std::size_t i = 0; i < img.names.size() && !plane; ++i)
    if (img.names[i].rfind(prefer, 0) == 0) plane = &img.planes[i];
  for (std::size_t i = 0; i < img.names.size() && !plane; ++i)
    if (img.names[i] != "hot") plane = &img.planes[i];
  if (!plane) return "<p class=\"missing\">" + esc(exr.filename().string()) + " holds no map.</p>\n";
  cv::Mat values(img.height, img.width, CV_32F, const_cast<float*>(plane->data()));
  std::vector<float> sorted(plane->data(), plane->data() + plane->size());
  std::erase_if(sorted, [](float v) { return !std::isfinite(v); });
  if (sorted.empty()) return "<p class=\"missing\">" + esc(exr.filename().string()) + ": no finite value.</p>\n";
  const auto pct = [&](double q) {
    auto it = sorted.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(sorted.size() - 1));
    std::nth_element(sorted.begin(), it, sorted.end());
    return static_cast<double>(*it);
  };
  const double lo = pct(0.01), hi = pct(0.99);
  cv::Mat scaled;
  values.convertTo(scaled, CV_8U, 255.0 / std::max(hi - lo, 1e-12), -lo * 255.0 / std::max(hi - lo, 1e-12));
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  int hot = 0;
  if (const ImageF* h = img.find("hot")) {
    const int radius = std::max(3, img.width / 200);
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x)
        if (h->data()[static_cast<std::size_t>(y) * img.width + x] > 0.5f) {
          cv::circle(colour, {x, y}, radius, cv::Scalar(0, 0, 255), std::max(1, radius / 3));
          ++hot;
        }
  }
  return fmt::format("<figure>{}<figcaption>{} ({}; colour scale from the 1st to the 99th percentile, {} to {}){}"
                     "</figcaption></figure>\n",
                     png_img(colour, what, max_px), esc(what), esc(exr.filename().string()), num(lo), num(hi),
                     hot ? fmt::format("; {} hot pixels circled in red", hot) : std::string());
}

std::string sphere_part(const fs::path& dir, const Json& sphere, int max_px) {
  std::string s = "<h3>Sphere (sphere.json)</h3>\n";
  const Json* inputs = at(sphere, {"provenance", "inputs"});
  fs::path image;
  if (inputs && inputs->is_array())
    for (const Json& in : *inputs) {
      const fs::path p = text_of(at(in, {"path"}), "");
      const fs::path local = dir / "captures" / "sphere" / p.filename();
      if (fs::exists(local)) image = local;
      else if (!p.empty() && fs::exists(p)) image = p;
      if (!image.empty()) break;
    }
  const Json* c = at(sphere, {"ellipse", "centre_px"});
  const Json* ax = at(sphere, {"ellipse", "semi_axes_px"});
  if (!image.empty() && c && ax && c->size() == 2 && ax->size() == 2) {
    cv::Mat raw = cv::imread(image.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
    if (!raw.empty()) {
      cv::Mat img8;
      double lo = 0, hi = 0;
      cv::minMaxLoc(raw, &lo, &hi);
      raw.convertTo(img8, CV_8U, 255.0 / std::max(hi - lo, 1.0), -lo * 255.0 / std::max(hi - lo, 1.0));
      cv::Mat bgr;
      cv::cvtColor(img8, bgr, cv::COLOR_GRAY2BGR);
      const cv::Point2f centre(number_or_nan(&(*c)[0]), number_or_nan(&(*c)[1]));
      const cv::Size2f axes(number_or_nan(&(*ax)[0]), number_or_nan(&(*ax)[1]));
      const int thick = std::max(1, bgr.cols / 400);
      cv::ellipse(bgr, centre, axes, number_or_nan(at(sphere, {"ellipse", "angle_deg"})), 0, 360,
                  cv::Scalar(0, 200, 255), thick, cv::LINE_AA);
      cv::drawMarker(bgr, centre, cv::Scalar(0, 200, 255), cv::MARKER_CROSS, 12 * thick, thick);
      s += fmt::format("<figure>{}<figcaption>The fitted silhouette (orange) on {}.</figcaption></figure>\n",
                       png_img(bgr, "sphere fit", max_px), esc(image.filename().string()));
    }
  }
  Table t;
  t.id = "sphere";
  t.head = {"figure", "value"};
  t.rows.push_back({"silhouette RMS (px)", with_id("sphere-rms-px", num_of(at(sphere, {"rms_px"})))});
  t.rows.push_back({"worst edge (px)", num_of(at(sphere, {"max_px"}))});
  t.rows.push_back({"edges used / found", text_of(at(sphere, {"edges_used"})) + " / " + text_of(at(sphere, {"edges_total"}))});
  t.rows.push_back({"centre (camera, m)", esc(numbers_text(at(sphere, {"centre_cam_m"}), 6))});
  t.rows.push_back({"centre standard deviation (m)", esc(numbers_text(at(sphere, {"centre_std_m"})))});
  t.rows.push_back({"radius (m)", num_of(at(sphere, {"radius_m"}))});
  s += table_html(t);
  return s;
}

std::string light_part(const Json& light, const RigConfig* rig) {
  std::string s = "<h3>Light positions (light.json)</h3>\n";
  if (rig) {
    // The arm as calibrated against the arm as rig.toml describes it (measured by hand).
    const RigGeometry& g = rig->geometry;
    Table t;
    t.id = "arm";
    t.head = {"arm", "nominal (rig.toml)", "calibrated (light.json)", "calibrated - nominal"};
    const auto row = [&](const char* what, double nominal, const Json* fitted, const Json* sd, double unit,
                         const char* unit_name, const std::string& id) {
      const double f = number_or_nan(fitted);
      t.rows.push_back({what, num(nominal * unit, 5) + " " + unit_name,
                        num(f * unit, 5) + (sd && sd->is_number() ? " ± " + num(sd->get<double>() * unit, 2) : "") + " " +
                            unit_name,
                        // Fixed decimals: 0.01 mm, 0.001 deg, whatever the size of the difference.
                        with_id(id, std::isfinite(f) ? fmt::format("{:+.{}f} {}", (f - nominal) * unit,
                                                                   unit == 1.0 ? 3 : 2, unit_name)
                                                     : "—")});
    };
    row("radius", g.arm_radius_m, at(light, {"arm_radius_m"}), at(light, {"std", "arm_radius_m"}), 1000.0, "mm",
        "arm-radius-diff-mm");
    row("height above the sphere centre", g.arm_height_m, at(light, {"arm_height_m"}), at(light, {"std", "arm_height_m"}),
        1000.0, "mm", "arm-height-diff-mm");
    row("azimuth at table 0", g.arm_zero_deg, at(light, {"zero_deg"}), at(light, {"std", "zero_deg"}), 1.0, "deg",
        "arm-zero-diff-deg");
    s += table_html(t);
    s += fmt::format("<p class=\"note\">Nominal: rig file <code>{}</code>. A difference of millimetres in the radius "
                     "or height, or a fraction of a degree in the zero, is the hand measurement's error the "
                     "calibration removes; much more means the arm moved or rig.toml describes another rig.</p>\n",
                     esc(rig->file.string()));
  }
  const Json* hl = at(light, {"highlights"});
  std::vector<std::vector<std::string>> unused;
  if (hl && hl->is_array()) {
    Series err = series("azimuth error", "linespoints", "#2e86c1", 1.5);
    for (const Json& h : *hl) {
      const Json* used = at(h, {"used"});
      if (used && used->is_boolean() && used->get<bool>()) {
        err.x.push_back(number_or_nan(at(h, {"table_angle_deg"})));
        err.y.push_back(number_or_nan(at(h, {"azimuth_error_deg"})));
      } else {
        unused.push_back({num_of(at(h, {"table_angle_deg"})), esc(text_of(at(h, {"reason"}), "not used"))});
      }
    }
    if (!err.x.empty()) {
      Plot p = make_plot("LED azimuth against the fitted arm", "table angle (deg)", "highlight azimuth - model (deg)");
      p.series = {err};
      s += plot_figure(p, fmt::format("Each used highlight's azimuth against the arm model (radius {} m, height {} m, "
                                      "zero {} deg): RMS {} deg, worst {} deg.",
                                      num_of(at(light, {"arm_radius_m"})), num_of(at(light, {"arm_height_m"})),
                                      num_of(at(light, {"zero_deg"})), num_of(at(light, {"rms_deg"})),
                                      num_of(at(light, {"max_deg"}))));
    }
  }
  if (!unused.empty()) {
    Table t;
    t.head = {"table angle (deg)", "why not used"};
    t.rows = std::move(unused);
    s += "<details><summary>" + fmt::format("{} highlights not used", t.rows.size()) + "</summary>" + table_html(t) +
         "</details>\n";
  }
  return s;
}

// "#rrggbb" of a CIELAB colour (D65) for a swatch; out-of-gamut values clipped.
std::string swatch(const Json* lab) {
  if (!lab || !lab->is_array() || lab->size() != 3) return "<span class=\"swatch\"></span>";
  const colour::Lab l{number_or_nan(&(*lab)[0]), number_or_nan(&(*lab)[1]), number_or_nan(&(*lab)[2])};
  const colour::Rgb rgb = colour::xyz_to_srgb(colour::lab_to_xyz(l, colour::d65()));
  int v[3];
  for (int c = 0; c < 3; ++c) {
    double x = std::clamp(std::isfinite(rgb[c]) ? rgb[c] : 0.0, 0.0, 1.0);
    x = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    v[c] = static_cast<int>(std::lround(x * 255.0));
  }
  return fmt::format("<span class=\"swatch\" style=\"background:#{:02x}{:02x}{:02x}\"></span>", v[0], v[1], v[2]);
}

std::string lab_text(const Json* lab) {
  if (!lab || !lab->is_array() || lab->size() != 3) return "—";
  return fmt::format("{} {} {}", num(number_or_nan(&(*lab)[0]), 4), num(number_or_nan(&(*lab)[1]), 3),
                     num(number_or_nan(&(*lab)[2]), 3));
}

std::string colour_chart_part(const Json& c) {
  std::string s = "<h3>Colour chart (colour.json)</h3>\n";
  s += fmt::format("<p>{} patches used; dE00 mean <span id=\"chart-mean-de00\">{}</span>, median {}, max {} ({}). "
                   "Model: {}; {}.</p>\n",
                   text_of(at(c, {"patches_used"})), num_of(at(c, {"mean_de00"})), num_of(at(c, {"median_de00"})),
                   num_of(at(c, {"max_de00"})), esc(text_of(at(c, {"worst_patch"}))), esc(text_of(at(c, {"model"}))),
                   esc(text_of(at(c, {"space"}))));
  const Json* patches = at(c, {"patches"});
  if (!patches || !patches->is_array()) return s;
  Table t;
  t.id = "chart";
  t.head = {"patch", "reference", "measured", "reference L* a* b*", "measured L* a* b*", "dE00", "used"};
  for (const Json& p : *patches) {
    const double de = number_or_nan(at(p, {"de00"}));
    t.rows.push_back({esc(text_of(at(p, {"name"}))), swatch(at(p, {"reference_lab"})), swatch(at(p, {"fitted_lab"})),
                      lab_text(at(p, {"reference_lab"})), lab_text(at(p, {"fitted_lab"})), num(de, 3),
                      text_of(at(p, {"used"}))});
    t.row_class.push_back(de > 2.0 ? "warn" : "");
  }
  s += table_html(t);
  return s;
}

}  // namespace

Section calibration_section(const fs::path& dir, const SectionOptions& o) {
  Section sec{"calibration", "Calibration", {}, {}, {}};
  std::string& s = sec.html;
  s += "<p>Folder <code>" + esc(dir.string()) + "</code>.</p>\n";
  Table overview;
  overview.id = "calibration-stages";
  overview.head = {"stage", "file", "figures", "left out", "date"};
  std::map<std::string, Json> files;
  for (const StageFile& f : kStages) {
    const fs::path p = dir / f.file;
    if (!fs::exists(p)) {
      overview.rows.push_back({f.stage, esc(f.file), "<span class=\"missing\">missing: run <code>" + esc(f.command) +
                                                         "</code></span>", "—", "—"});
      overview.row_class.push_back("missing");
      sec.missing.push_back(fmt::format("calibration: {} not found (run {})", f.file, f.command));
      continue;
    }
    Json j = read_json_file(p);
    overview.rows.push_back({f.stage, esc(f.file), esc(stage_figures(f.stage, j)), esc(left_out(f.stage, j)),
                             esc(text_of(at(j, {"provenance", "date"})))});
    overview.row_class.push_back("");
    files[f.stage] = std::move(j);
  }
  s += table_html(overview);
  if (files.count("intrinsics")) s += intrinsics_part(files["intrinsics"]);
  if (files.count("response")) s += response_part(files["response"]);
  if (files.count("dark") || files.count("flat")) {
    s += "<h3>Dark and flat maps</h3>\n<div class=\"row\">";
    if (files.count("dark"))
      s += map_part(dir / text_of(at(files["dark"], {"maps", "file"}), "dark.exr"), "rate",
                    "dark current (DN/s)", o.max_image_px / 2 + 20);
    if (files.count("flat"))
      s += map_part(dir / text_of(at(files["flat"], {"maps", "file"}), "flat.exr"), "flat", "flat field (relative gain)",
                    o.max_image_px / 2 + 20);
    s += "</div>\n";
  }
  if (files.count("sphere")) s += sphere_part(dir, files["sphere"], o.max_image_px);
  if (files.count("light")) s += light_part(files["light"], o.rig);
  if (files.count("colour")) s += colour_chart_part(files["colour"]);
  return sec;
}

}  // namespace paintlab::report
