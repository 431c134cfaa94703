#include "paintlab/report/report.h"

#include <fmt/format.h>

#include <optional>

#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/rig.h"
#include "paintlab/core/version.h"
#include "paintlab/fitting/compare.h"
#include "report_parts.h"

namespace paintlab::report {
namespace fs = std::filesystem;

const char* to_string(InputKind k) {
  switch (k) {
    case InputKind::Calibration: return "calibration folder";
    case InputKind::Session: return "session";
    case InputKind::Fit: return "fit";
    case InputKind::Demo: return "demo folder";
  }
  return "?";
}

namespace {

constexpr const char* kCalibrationFiles[] = {"camera.json", "check.json", "response.json", "dark.json", "flat.json",
                                              "sphere.json", "light.json", "scale.json", "colour.json"};

bool is_calibration_folder(const fs::path& dir) {
  for (const char* f : kCalibrationFiles)
    if (fs::exists(dir / f)) return true;
  return false;
}

constexpr const char* kStyle = R"css(
body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 0 auto; max-width: 1100px; padding: 0 1.5em 3em;
       color: #222; line-height: 1.4; font-size: 15px; }
header { border-bottom: 2px solid #2e86c1; margin-bottom: 1em; }
h1 { margin: 0.6em 0 0.2em; font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-top: 0.6em; }
h3 { margin-top: 1.4em; }
nav a { margin-right: 1em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #eef3f8; }
tr.fail td, tr.missing td { background: #fdecea; } tr.warn td { background: #fff6e0; }
.verdict { font-weight: bold; padding: 0.4em 0.7em; display: inline-block; border-radius: 4px; }
.verdict.pass { background: #e7f6ea; color: #1e6b30; } .verdict.fail { background: #fdecea; color: #a12a1f; }
.missing { color: #a12a1f; } .note { color: #555; font-size: 0.9em; }
figure { margin: 0.8em 0; display: inline-block; vertical-align: top; } figcaption { font-size: 0.88em; color: #444; max-width: 720px; }
img { max-width: 100%; height: auto; }
.swatch { display: inline-block; width: 2.2em; height: 1.2em; border: 1px solid #888; }
.row figure { margin-right: 1em; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
@media print {
  body { max-width: none; font-size: 11pt; } nav { display: none; }
  section { page-break-before: always; } figure, table { page-break-inside: avoid; }
  details { display: block; } details > summary { display: none; }
  .verdict { border: 1px solid #888; }
}
)css";

std::string sha_or_dash(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) return "—";
  return sha256_file(p);
}

Section provenance_section(const ReportInput& in) {
  Section sec{"provenance", "Provenance", {}, {}, {}};
  Table t;
  t.id = "provenance-files";
  t.head = {"file", "SHA-256", "written by", "date"};
  const auto add = [&](const fs::path& p, const std::string& label) {
    std::string version = "—", date = "—";
    if (p.extension() == ".json" && fs::exists(p)) {
      try {
        const Json j = read_json_file(p);
        version = text_of(at(j, {"provenance", "software_version"}), text_of(at(j, {"software_version"})));
        date = text_of(at(j, {"provenance", "date"}), text_of(at(j, {"date"}), text_of(at(j, {"created_utc"}))));
      } catch (const Error&) {
        version = "unreadable";  // its own section says what is wrong with it
      }
    }
    t.rows.push_back({esc(label), "<code>" + sha_or_dash(p) + "</code>", esc(version), esc(date)});
  };
  if (!in.calibration.empty())
    for (const char* f : kCalibrationFiles)
      if (fs::exists(in.calibration / f)) add(in.calibration / f, "calibration/" + std::string(f));
  if (!in.session.empty()) {
    add(in.session / "session.json", "session/session.json");
    add(in.session / "journal.jsonl", "session/journal.jsonl");
  }
  if (!in.fit.empty()) add(in.fit, in.fit.filename().string());
  if (!in.flakes.empty()) add(in.flakes, in.flakes.filename().string());
  if (!in.summary.empty()) add(in.summary, "summary.json");
  if (!in.rig.empty()) add(in.rig, "rig file " + in.rig.filename().string());
  std::string& s = sec.html;
  s += fmt::format("<p>Report written by paintlab <span id=\"software-version\">{}</span> on {} from the {} "
                   "<code>{}</code>.</p>\n",
                   esc(software_version()), esc(utc_timestamp()), to_string(in.kind), esc(in.path.string()));
  s += table_html(t);
  // The calibration a session was measured with, against the calibration files now.
  if (!in.session.empty() && fs::exists(in.session / "session.json")) {
    const Json session = read_json_file(in.session / "session.json");
    s += fmt::format("<p>Rig <b>{}</b> (<code>{}</code>, SHA-256 <code>{}</code>).</p>\n",
                     esc(text_of(at(session, {"rig", "name"}))), esc(text_of(at(session, {"rig", "file"}))),
                     esc(text_of(at(session, {"rig", "sha256"}))));
    if (const Json* cal = at(session, {"calibration"}); cal && cal->is_object() && !in.calibration.empty()) {
      Table c;
      c.id = "provenance-calibration";
      c.head = {"calibration file", "when measured", "now", ""};
      for (const auto& [file, digest] : cal->items()) {
        const std::string then = text_of(&digest);
        const fs::path now_file = in.calibration / file;
        std::string now = fs::exists(now_file) ? sha256_file(now_file) : "missing";
        // session.json may record a shortened digest: compare its length.
        const bool same = now.size() >= then.size() && now.compare(0, then.size(), then) == 0;
        // The first 16 hex digits are enough to tell files apart on the page (the full ones are above).
        const auto short_hex = [](const std::string& h) { return h.size() > 16 ? h.substr(0, 16) + "…" : h; };
        c.rows.push_back({esc(file), "<code>" + esc(short_hex(then)) + "</code>",
                          "<code>" + esc(short_hex(now.substr(0, then.size()))) + "</code>",
                          same ? "same" : "<b>changed since the measurement</b>"});
        c.row_class.push_back(same ? "" : "warn");
      }
      s += "<h3>Calibration used by the measurement</h3>\n" + table_html(c);
    }
  }
  return sec;
}

Section demo_section(const Json& summary) {
  Section sec{"summary", "Demo summary", {}, {}, {}};
  std::string& s = sec.html;
  const Json* truth = at(summary, {"truth_seen_by_camera"});
  if (!truth) truth = at(summary, {"truth"});
  const Json* fit = at(summary, {"fit"});
  if (truth && fit) {
    s += "<p>The simulator's paint (truth) against the fit:</p>\n<pre id=\"demo-compare\">" +
         esc(fit::compare_table(*truth, *fit, fit->value("stddev", Json::object()))) + "</pre>\n";
  }
  Table cal;
  cal.id = "demo-calibration";
  cal.head = {"calibration against the simulator's truth", "value"};
  if (const Json* c = at(summary, {"calibration"}); c && c->is_object())
    for (const auto& [k, v] : c->items()) cal.rows.push_back({esc(k), with_id("demo-" + k, num_of(&v))});
  s += table_html(cal);
  Table tm;
  tm.head = {"step", "time (s)"};
  if (const Json* c = at(summary, {"timings_s"}); c && c->is_object())
    for (const auto& [k, v] : c->items()) tm.rows.push_back({esc(k), num_of(&v, 3)});
  s += table_html(tm);
  return sec;
}

}  // namespace

ReportInput classify_input(const fs::path& input) {
  ReportInput in;
  std::error_code ec;
  in.path = fs::absolute(input, ec);
  if (ec || !fs::exists(in.path))
    throw DataError(fmt::format("report {}: not found (give a calibration folder, a session folder, a fit.json or a "
                                "demo folder)",
                                input.string()));
  const fs::path& p = in.path;
  if (fs::is_directory(p)) {
    if (fs::exists(p / "summary.json")) {
      in.kind = InputKind::Demo;
      in.summary = p / "summary.json";
      if (fs::exists(p / "calib")) in.calibration = p / "calib";
      if (fs::exists(p / "session")) in.session = p / "session";
      in.fit = p / "fit.json";
      if (fs::exists(p / "flakes.json")) in.flakes = p / "flakes.json";
      if (fs::exists(p / "rig.toml")) in.rig = p / "rig.toml";
      for (const char* img : {"preview.png", "compare.png"})
        if (fs::exists(p / img)) in.images.push_back(p / img);
      return in;
    }
    if (fs::exists(p / "session.json")) {
      in.kind = InputKind::Session;
      in.session = p;
      const Json session = read_json_file(p / "session.json");
      if (const Json* rig = at(session, {"rig", "file"}); rig && rig->is_string() && fs::exists(rig->get<std::string>()))
        in.rig = rig->get<std::string>();
      return in;
    }
    if (is_calibration_folder(p)) {
      in.kind = InputKind::Calibration;
      in.calibration = p;
      // rig.toml beside the folder, when its `calibration` names this folder.
      const fs::path beside = p.parent_path() / "rig.toml";
      if (fs::exists(beside)) {
        try {
          if (fs::equivalent(RigConfig::load(beside).calibration_dir, p)) in.rig = beside;
        } catch (const Error&) {
          // Another rig's file, or a broken one: not this folder's rig; the page goes without it.
        }
      }
      return in;
    }
    throw DataError(fmt::format(
        "report {}: this folder is none of the four kinds a report is made of: no summary.json (a demo folder), no "
        "session.json (a session), no calibration file (camera.json, check.json, response.json, ...)",
        input.string()));
  }
  if (p.extension() == ".json") {
    const Json j = read_json_file(p);
    if (j.is_object() && j.contains("model") && (j.contains("residual") || j.contains("lobes") || j.contains("kd"))) {
      in.kind = InputKind::Fit;
      in.fit = p;
      if (fs::exists(p.parent_path() / "flakes.json")) in.flakes = p.parent_path() / "flakes.json";
      for (const char* img : {"preview.png", "compare.png"})
        if (fs::exists(p.parent_path() / img)) in.images.push_back(p.parent_path() / img);
      return in;
    }
    throw DataError(fmt::format("report {}: a JSON file that is not a fit (no 'model' with parameters or residuals); "
                                "give a fit.json, or the folder of a calibration, session or demo",
                                input.string()));
  }
  throw DataError(fmt::format("report {}: not a folder and not a fit.json (give a calibration folder, a session "
                              "folder, a fit.json or a demo folder)",
                              input.string()));
}

Report make_report(const ReportInput& in, const ReportOptions& options) {
  SectionOptions so;
  so.max_image_px = options.max_image_px;
  std::optional<RigConfig> rig;
  const fs::path rig_file = options.rig.empty() ? in.rig : options.rig;
  if (!rig_file.empty()) {
    rig = RigConfig::load(rig_file);
    so.rig = &*rig;
  }
  std::vector<Section> sections;
  Json summary;
  if (!in.summary.empty()) {
    summary = read_json_file(in.summary);
    if (!summary.is_object()) throw DataError(in.summary.string() + ": expected a JSON object");
    sections.push_back(demo_section(summary));
  }
  if (in.kind == InputKind::Calibration || in.kind == InputKind::Demo) {
    if (!in.calibration.empty()) {
      sections.push_back(calibration_section(in.calibration, so));
      sections.push_back(check_section(in.calibration / "check.json", so));
    } else {
      Section s{"calibration", "Calibration", "<p class=\"missing\">No calibration folder.</p>\n", {"calibration: folder not found"}, {}};
      sections.push_back(s);
    }
  }
  if (in.kind == InputKind::Session || in.kind == InputKind::Demo) {
    if (!in.session.empty()) sections.push_back(measurement_section(in.session, so));
    else sections.push_back({"measurement", "Measurement", "<p class=\"missing\">No session folder.</p>\n", {"measurement: session folder not found"}, {}});
  }
  if (in.kind == InputKind::Fit || in.kind == InputKind::Demo) {
    sections.push_back(fit_section(in.fit, in.images, so));
    sections.push_back(colour_section(in.fit, summary.is_object() ? &summary : nullptr, so));
    if (!in.flakes.empty()) sections.push_back(sparkle_section(in.flakes, so));
  }
  ReportInput used = in;
  used.rig = rig_file;
  sections.push_back(provenance_section(used));

  Report r;
  for (const Section& s : sections) {
    r.sections.push_back(s.id);
    r.missing.insert(r.missing.end(), s.missing.begin(), s.missing.end());
    r.failing.insert(r.failing.end(), s.failing.begin(), s.failing.end());
  }
  std::string title = options.title;
  if (title.empty()) {
    std::string name = in.path.filename().string();
    if (!summary.is_null()) name = text_of(at(summary, {"paint"}), name);
    title = fmt::format("paintlab report: {} ({})", name, to_string(in.kind));
  }
  std::string& h = r.html;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<title>" + esc(title) + "</title>\n<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n";
  h += "<header><h1>" + esc(title) + "</h1>\n<p>" + esc(in.path.string()) + " — written " + esc(utc_timestamp()) +
       " by paintlab " + esc(software_version()) + "</p>\n<nav>";
  for (const Section& s : sections) h += fmt::format("<a href=\"#{}\">{}</a>", s.id, esc(s.title));
  h += "</nav></header>\n";
  h += "<section id=\"status\"><h2>Status</h2>\n";
  if (r.failing.empty() && r.missing.empty())
    h += "<p class=\"verdict pass\" id=\"status-verdict\">Complete: nothing missing, nothing failing.</p>\n";
  if (!r.failing.empty()) {
    h += "<p class=\"verdict fail\" id=\"status-verdict\">Failing:</p>\n<ul id=\"status-failing\">";
    for (const std::string& f : r.failing) h += "<li>" + esc(f) + "</li>";
    h += "</ul>\n";
  }
  if (!r.missing.empty()) {
    h += "<p class=\"missing\">Missing:</p>\n<ul id=\"status-missing\">";
    for (const std::string& m : r.missing) h += "<li>" + esc(m) + "</li>";
    h += "</ul>\n";
  }
  h += "</section>\n";
  for (const Section& s : sections)
    h += fmt::format("<section id=\"{}\">\n<h2>{}</h2>\n{}</section>\n", s.id, esc(s.title), s.html);
  h += "</body>\n</html>\n";
  return r;
}

}  // namespace paintlab::report
