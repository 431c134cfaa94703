#pragma once
// Plots for reports, drawn by gnuplot's SVG terminal (gnuplot-nox; docs/reports.md says why
// gnuplot): the data go to gnuplot on its standard input as inline data blocks, the SVG comes
// back on its standard output. No temporary files, no network, no fonts outside the SVG.
#include <string>
#include <vector>

namespace paintlab::report {

struct Series {
  std::string title;            // legend entry ("" for none)
  std::vector<double> x, y;     // same length; non-finite points are left out
  std::string style = "lines";  // gnuplot style: lines, points, linespoints, impulses, boxes
  std::string colour;           // "#rrggbb", or "" for gnuplot's sequence
  double width = 1.5;           // line width or point size
  int point_type = 7;           // gnuplot point type (7: filled circle)
  std::vector<double> dx, dy;   // style "vectors": arrows from (x, y) by (dx, dy)
  std::vector<double> z;        // style "image": a value per (x, y) on a regular grid (NaN: no value)
};

// A series without data yet.
inline Series series(std::string title, std::string style, std::string colour, double width) {
  Series s;
  s.title = std::move(title);
  s.style = std::move(style);
  s.colour = std::move(colour);
  s.width = width;
  return s;
}

struct Plot {
  std::string title;
  std::string xlabel, ylabel;
  bool log_y = false;
  int width_px = 640, height_px = 380;
  std::vector<Series> series;
  std::vector<std::string> settings;  // further gnuplot `set` lines (e.g. "xrange [0:90]")
};

// A plot with its title, axis labels and size, no series yet.
inline Plot make_plot(std::string title, std::string xlabel, std::string ylabel, int width_px = 640,
                      int height_px = 380) {
  Plot p;
  p.title = std::move(title);
  p.xlabel = std::move(xlabel);
  p.ylabel = std::move(ylabel);
  p.width_px = width_px;
  p.height_px = height_px;
  return p;
}

// The plot as a standalone SVG document. IoError when gnuplot is not installed or fails
// (naming it and what it printed); DataError for a plot without a single finite point.
std::string plot_svg(const Plot& plot);

// The gnuplot script plot_svg runs (for tests and for readers who want to re-plot).
std::string gnuplot_script(const Plot& plot);

}  // namespace paintlab::report
