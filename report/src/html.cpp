#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "report_parts.h"

namespace paintlab::report {

std::string esc(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string num(double v, int significant) {
  if (!std::isfinite(v)) return "—";
  return fmt::format("{:.{}g}", v, significant);
}

const Json* at(const Json& j, std::initializer_list<std::string_view> path) {
  const Json* p = &j;
  for (std::string_view key : path) {
    if (!p->is_object()) return nullptr;
    const auto it = p->find(std::string(key));
    if (it == p->end()) return nullptr;
    p = &*it;
  }
  return p;
}

double number_or_nan(const Json* j) {
  return j && j->is_number() ? j->get<double>() : std::nan("");
}

std::string num_of(const Json* j, int significant) { return num(number_or_nan(j), significant); }

std::string text_of(const Json* j, std::string fallback) {
  if (!j || j->is_null()) return fallback;
  if (j->is_string()) return j->get<std::string>();
  if (j->is_number_integer()) return j->dump();
  if (j->is_number()) return num(j->get<double>());
  if (j->is_boolean()) return j->get<bool>() ? "yes" : "no";
  return j->dump();
}

std::string numbers_text(const Json* j, int significant) {
  if (!j || j->is_null()) return "—";
  if (j->is_number()) return num(j->get<double>(), significant);
  if (!j->is_array()) return text_of(j);
  std::string s;
  for (const Json& v : *j) s += (s.empty() ? "" : ", ") + numbers_text(&v, significant);
  return s;
}

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const auto n = (static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16) |
                   (static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8) |
                   static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += kAlphabet[n & 63];
  }
  if (i < bytes.size()) {
    unsigned n = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8;
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string png_img(const cv::Mat& bgr8, const std::string& alt, int max_width) {
  cv::Mat shown = bgr8;
  if (max_width > 0 && bgr8.cols > max_width) {
    const double f = static_cast<double>(max_width) / bgr8.cols;
    cv::resize(bgr8, shown, cv::Size(), f, f, cv::INTER_AREA);
  }
  std::vector<unsigned char> png;
  cv::imencode(".png", shown, png, {cv::IMWRITE_PNG_COMPRESSION, 6});
  return fmt::format("<img alt=\"{}\" width=\"{}\" height=\"{}\" src=\"data:image/png;base64,{}\">", esc(alt),
                     shown.cols, shown.rows,
                     base64(std::string_view(reinterpret_cast<const char*>(png.data()), png.size())));
}

std::string png_file_img(const std::filesystem::path& file, const std::string& alt, int max_width) {
  const cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);
  if (image.empty()) return {};
  if (image.cols <= max_width) {
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return fmt::format("<img alt=\"{}\" width=\"{}\" height=\"{}\" src=\"data:image/png;base64,{}\">", esc(alt),
                       image.cols, image.rows, base64(bytes));
  }
  return png_img(image, alt, max_width);
}

std::string plot_figure(const Plot& plot, const std::string& caption) {
  const std::string svg = plot_svg(plot);
  return fmt::format(
      "<figure class=\"plot\"><img alt=\"{}\" width=\"{}\" height=\"{}\" src=\"data:image/svg+xml;base64,{}\">"
      "<figcaption>{}</figcaption></figure>\n",
      esc(plot.title), plot.width_px, plot.height_px, base64(svg), caption);
}

std::string with_id(const std::string& id, const std::string& html) { return "#" + id + "|" + html; }

std::string table_html(const Table& t) {
  std::string s = t.id.empty() ? "<table>" : fmt::format("<table id=\"{}\">", esc(t.id));
  s += "<thead><tr>";
  for (const std::string& h : t.head) s += "<th>" + h + "</th>";
  s += "</tr></thead><tbody>\n";
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const std::string cls = r < t.row_class.size() ? t.row_class[r] : std::string();
    s += cls.empty() ? "<tr>" : fmt::format("<tr class=\"{}\">", cls);
    for (const std::string& cell : t.rows[r]) {
      if (cell.size() > 1 && cell[0] == '#') {
        const auto bar = cell.find('|');
        if (bar != std::string::npos) {
          s += fmt::format("<td id=\"{}\">{}</td>", cell.substr(1, bar - 1), cell.substr(bar + 1));
          continue;
        }
      }
      s += "<td>" + cell + "</td>";
    }
    s += "</tr>\n";
  }
  return s + "</tbody></table>\n";
}

}  // namespace paintlab::report
