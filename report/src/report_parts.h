#pragma once
// The parts of a report page (report.cpp puts them together): HTML helpers and one builder
// per section. Private to the report module.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/report/plot.h"

namespace paintlab::report {

// --- HTML ---
std::string esc(std::string_view text);                // &, <, >, " escaped
std::string num(double v, int significant = 4);        // "—" for non-finite
std::string num_of(const Json* j, int significant = 4);  // a JSON number, or "—"
std::string base64(std::string_view bytes);
// <img> with the picture inline (PNG), scaled down to at most max_width pixels wide.
std::string png_img(const cv::Mat& bgr8, const std::string& alt, int max_width);
// <img> of a PNG file as it is (scaled down when wider than max_width); "" when unreadable.
std::string png_file_img(const std::filesystem::path& file, const std::string& alt, int max_width);
// <figure> with the plot as an inline SVG image (data: URI) and its caption.
std::string plot_figure(const Plot& plot, const std::string& caption);
// A table; cells are HTML (escape text with esc()). `id` ("" for none).
struct Table {
  std::string id;
  std::vector<std::string> head;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row_class;  // per row ("" for none); may be shorter than rows
};
std::string table_html(const Table& t);
// A cell carrying an id so that tests and scripts find the value: <td id=ID>text</td> is
// made by table_html when the cell starts with "#ID|".
std::string with_id(const std::string& id, const std::string& html);

// JSON lookups that tolerate absence: the value at key path, or nullptr.
const Json* at(const Json& j, std::initializer_list<std::string_view> path);
double number_or_nan(const Json* j);
std::string text_of(const Json* j, std::string fallback = "—");
// A JSON number or array of numbers as "a, b, c" to `significant` digits; "—" when absent.
std::string numbers_text(const Json* j, int significant = 4);

// --- sections ---
struct Section {
  std::string id;     // HTML id ("calibration", "check", ...)
  std::string title;
  std::string html;   // body
  std::vector<std::string> missing;
  std::vector<std::string> failing;
};
struct SectionOptions {
  int max_image_px = 720;
  const RigConfig* rig = nullptr;  // the nominal geometry, when the rig file is known
};

Section calibration_section(const std::filesystem::path& dir, const SectionOptions& o);
Section check_section(const std::filesystem::path& check_json, const SectionOptions& o);
Section measurement_section(const std::filesystem::path& session_dir, const SectionOptions& o);
Section fit_section(const std::filesystem::path& fit_json, const std::vector<std::filesystem::path>& images,
                    const SectionOptions& o);
// Colour: a demo's truth | fit | measured table (summary.json "colour"), else the fit's
// model colour per geometry. `summary` may be null.
Section colour_section(const std::filesystem::path& fit_json, const Json* summary, const SectionOptions& o);
// Sparkle: the flakes.json of `paintlab flakes` (a demo's, or beside a fit.json).
Section sparkle_section(const std::filesystem::path& flakes_json, const SectionOptions& o);

}  // namespace paintlab::report
