#include "paintlab/report/plot.h"

#include <fmt/format.h>

#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/core/process.h"

namespace paintlab::report {
namespace {

// A string as a gnuplot double-quoted literal.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string gnuplot_script(const Plot& plot) {
  std::string s;
  s += fmt::format("set terminal svg size {},{} dynamic enhanced font \"sans,11\" background rgb \"white\"\n",
                   plot.width_px, plot.height_px);
  s += "set encoding utf8\nset grid lc rgb \"#dddddd\"\nset key top right box opaque\nset border lc rgb \"#444444\"\n";
  if (!plot.title.empty()) s += "set title " + quoted(plot.title) + "\n";
  if (!plot.xlabel.empty()) s += "set xlabel " + quoted(plot.xlabel) + "\n";
  if (!plot.ylabel.empty()) s += "set ylabel " + quoted(plot.ylabel) + "\n";
  if (plot.log_y) s += "set logscale y\nset format y \"10^{%L}\"\n";
  bool titled = false;
  for (const Series& d : plot.series) titled = titled || !d.title.empty();
  if (!titled) s += "unset key\n";
  for (const std::string& line : plot.settings) s += "set " + line + "\n";
  std::size_t finite = 0;
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const Series& d = plot.series[k];
    s += fmt::format("$d{} << EOD\n", k);
    const bool vectors = d.style == "vectors";
    const bool image = d.style == "image";
    for (std::size_t i = 0; i < d.x.size() && i < d.y.size(); ++i) {
      if (!std::isfinite(d.x[i]) || !std::isfinite(d.y[i]) || (plot.log_y && !(d.y[i] > 0.0))) continue;
      if (image) {
        if (i >= d.z.size()) continue;
        s += std::isfinite(d.z[i]) ? fmt::format("{:.9g} {:.9g} {:.6g}\n", d.x[i], d.y[i], d.z[i])
                                   : fmt::format("{:.9g} {:.9g} NaN\n", d.x[i], d.y[i]);
      } else if (vectors) {
        if (i >= d.dx.size() || i >= d.dy.size() || !std::isfinite(d.dx[i]) || !std::isfinite(d.dy[i])) continue;
        s += fmt::format("{:.9g} {:.9g} {:.9g} {:.9g}\n", d.x[i], d.y[i], d.dx[i], d.dy[i]);
      } else {
        s += fmt::format("{:.9g} {:.9g}\n", d.x[i], d.y[i]);
      }
      ++finite;
    }
    s += "EOD\n";
  }
  if (finite == 0) throw DataError(fmt::format("plot '{}': no finite point to draw", plot.title));
  s += "plot ";
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const Series& d = plot.series[k];
    if (k) s += ", \\\n     ";
    if (d.style == "vectors") s += fmt::format("$d{} using 1:2:3:4 with vectors head size 3,20 filled", k);
    else if (d.style == "image") s += fmt::format("$d{} using 1:2:3 with image", k);
    else s += fmt::format("$d{} using 1:2 with {}", k, d.style);
    const bool points = d.style == "points" || d.style == "linespoints";
    if (points) s += fmt::format(" pt {} ps {:.2g}", d.point_type, d.width * 0.4);
    if (d.style != "points" && d.style != "image") s += fmt::format(" lw {:.2g}", d.width);
    if (!d.colour.empty() && d.style != "image") s += " lc rgb " + quoted(d.colour);
    if (d.style == "boxes") s += " fs solid 0.6";
    s += d.title.empty() ? " notitle" : " title " + quoted(d.title);
  }
  return s + "\n";
}

std::string plot_svg(const Plot& plot) {
  const std::string script = gnuplot_script(plot);
  const ProcessOutput r = run_process_capture("gnuplot", {}, script, 60.0);
  if (r.exit_code != 0 || r.out.find("<svg") == std::string::npos)
    throw IoError("gnuplot", fmt::format("plot '{}' failed (exit {}): {}", plot.title, r.exit_code,
                                         r.err.substr(0, 400)));
  return r.out;
}

}  // namespace paintlab::report
