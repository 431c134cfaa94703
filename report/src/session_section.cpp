// The rig check and the measurement sections (docs/reports.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "report_parts.h"

namespace paintlab::report {
namespace fs = std::filesystem;

Section check_section(const fs::path& check_json, const SectionOptions&) {
  Section sec{"check", "Rig check", {}, {}, {}};
  if (!fs::exists(check_json)) {
    sec.html = "<p class=\"missing\">No rig check: " + esc(check_json.string()) +
               " not found. Run <code>paintlab check --rig rig.toml</code>.</p>\n";
    sec.missing.push_back("check: check.json not found (run paintlab check)");
    return sec;
  }
  const Json j = read_json_file(check_json);
  const Json* checks = at(j, {"checks"});
  const bool passed = at(j, {"passed"}) && at(j, {"passed"})->is_boolean() && at(j, {"passed"})->get<bool>();
  std::vector<const Json*> rows;
  if (checks && checks->is_array())
    for (const Json& c : *checks) rows.push_back(&c);
  const auto failed = [](const Json* c) {
    const Json* p = at(*c, {"pass"});
    return !(p && p->is_boolean() && p->get<bool>());
  };
  std::stable_partition(rows.begin(), rows.end(), failed);
  const long failures = std::count_if(rows.begin(), rows.end(), failed);
  sec.html += fmt::format(
      "<p class=\"verdict {}\" id=\"check-verdict\">{}: {} of {} checks failed ({}, rig {}).</p>\n",
      passed ? "pass" : "fail", passed ? "PASSED" : "FAILED", failures, rows.size(), esc(text_of(at(j, {"date"}))),
      esc(text_of(at(j, {"rig"}))));
  Table t;
  t.id = "checks";
  t.head = {"result", "check", "value", "limit", "what to do"};
  for (const Json* c : rows) {
    const bool bad = failed(c);
    const std::string limit = text_of(at(*c, {"limit"}), "");
    const Json* tol = at(*c, {"tolerance"});
    std::string lim;
    if (limit == "at_most") lim = "≤ " + num_of(tol);
    else if (limit == "at_least") lim = "≥ " + num_of(tol);
    else if (limit == "required") lim = "required";
    else lim = esc(limit) + (tol && !tol->is_null() ? " " + num_of(tol) : std::string());
    const std::string unit = text_of(at(*c, {"unit"}), "");
    const Json* value = at(*c, {"value"});
    std::string v = value && !value->is_null() ? num_of(value) : (bad ? "missing" : "present");
    if (!unit.empty() && value && value->is_number()) v += " " + esc(unit);
    const std::string id = text_of(at(*c, {"id"}), "");
    t.rows.push_back({bad ? "<b>FAIL</b>" : "pass",
                      esc(text_of(at(*c, {"what"}), id)) + "<br><small>" + esc(id) + "</small>",
                      with_id("check-" + id, v), lim + (unit.empty() || !tol || tol->is_null() ? "" : " " + esc(unit)),
                      bad ? esc(text_of(at(*c, {"action"}), "")) : ""});
    t.row_class.push_back(bad ? "fail" : "");
    if (bad) sec.failing.push_back(fmt::format("check {}: {} (value {}, limit {})", id, text_of(at(*c, {"what"}), id),
                                               text_of(value, "missing"), text_of(tol, limit)));
  }
  sec.html += table_html(t);
  return sec;
}

namespace {

// The runs of a session (runs.jsonl, one line a `paintlab measure` run): what each measured,
// how it ended, its sweep against the physical minimum, retries.
std::string runs_part(const fs::path& dir) {
  const fs::path file = dir / "runs.jsonl";
  if (!fs::exists(file))
    return "<p class=\"note\">No runs.jsonl (a session measured before paintlab recorded its runs): the timeline "
           "below is from the journal alone.</p>\n";
  bool torn = false;
  const std::vector<Json> runs = read_jsonl_file(file, &torn);
  Table t;
  t.id = "runs";
  t.head = {"run", "ended (UTC)", "positions measured", "outcome", "sweep (rig clock)", "physical minimum",
            "sweep / minimum", "frames", "retries"};
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const Json& r = runs[k];
    const auto flag = [&](const char* key) {
      const Json* v = at(r, {key});
      return v && v->is_boolean() && v->get<bool>();
    };
    std::string outcome = flag("complete") ? "complete" : flag("interrupted") ? "stopped (Ctrl-C)"
                                                      : flag("device_fault") ? "device fault"
                                                                              : "stopped";
    const std::string reason = text_of(at(r, {"stop_reason"}), "");
    if (!reason.empty()) outcome += ": " + reason;
    if (const Json* f = at(r, {"resume_findings"}); f && f->is_array() && !f->empty())
      outcome += fmt::format(" (resume found: {})", numbers_text(f));
    const double sweep = number_or_nan(at(r, {"sweep_s"})), minimum = number_or_nan(at(r, {"physical_min_s"}));
    t.rows.push_back({std::to_string(k + 1), esc(text_of(at(r, {"utc_end"}))),
                      fmt::format("{} (of {}; {} before)", text_of(at(r, {"measured"})), text_of(at(r, {"positions"})),
                                  text_of(at(r, {"finished_before"}))),
                      esc(outcome), num(sweep) + " s", num(minimum) + " s", with_id(fmt::format("run{}-ratio", k + 1), num(sweep / minimum, 4)),
                      text_of(at(r, {"frames"})), text_of(at(r, {"retries"}))});
    t.row_class.push_back(flag("complete") ? "" : "warn");
  }
  return "<h3>Runs</h3>\n" + table_html(t) +
         "<p class=\"note\">Physical minimum: the table's motion profile, the settle waits, the exposures, the "
         "readouts and the filter wheel's moves, on the rig clock; sweep / minimum near 1 means the software adds "
         "almost nothing.</p>\n" +
         (torn ? "<p class=\"missing\">runs.jsonl ends in a torn line.</p>\n" : "");
}

}  // namespace

Section measurement_section(const fs::path& dir, const SectionOptions&) {
  Section sec{"measurement", "Measurement", {}, {}, {}};
  std::string& s = sec.html;
  const fs::path session_file = dir / "session.json";
  if (!fs::exists(session_file)) {
    s = "<p class=\"missing\">No session: " + esc(session_file.string()) + " not found.</p>\n";
    sec.missing.push_back("measurement: session.json not found");
    return sec;
  }
  const Json session = read_json_file(session_file);
  bool torn = false;
  std::vector<Json> journal;
  if (fs::exists(dir / "journal.jsonl")) journal = read_jsonl_file(dir / "journal.jsonl", &torn);
  else sec.missing.push_back("measurement: journal.jsonl not found (no position finished)");
  std::vector<double> planned;
  if (const Json* a = at(session, {"plan", "angles_deg"}); a && a->is_array())
    for (const Json& v : *a) planned.push_back(number_or_nan(&v));
  std::set<long long> done;
  for (const Json& r : journal)
    if (const Json* i = at(r, {"index"}); i && i->is_number_integer()) done.insert(i->get<long long>());
  const std::size_t missing = planned.size() > done.size() ? planned.size() - done.size() : 0;
  s += fmt::format("<p>Sample <b>{}</b>, started {}, software {}. Camera {} ({}, {}), colour space {}.</p>\n",
                   esc(text_of(at(session, {"sample"}))), esc(text_of(at(session, {"created_utc"}))),
                   esc(text_of(at(session, {"software_version"}))), esc(text_of(at(session, {"devices", "camera", "serial"}))),
                   esc(text_of(at(session, {"options", "pixel_format"}))), esc(text_of(at(session, {"options", "demosaic"}), "mono")),
                   esc(text_of(at(session, {"options", "colour_space"}))));
  s += fmt::format("<p class=\"verdict {}\" id=\"session-positions\">{} of {} light positions finished{}.</p>\n",
                   missing ? "fail" : "pass", done.size(), planned.size(),
                   missing ? fmt::format("; {} missing: the session is incomplete, resume it with "
                                         "<code>paintlab measure --resume {}</code>",
                                         missing, esc(dir.string()))
                           : std::string());
  if (missing) sec.missing.push_back(fmt::format("measurement: {} of {} light positions missing", missing, planned.size()));
  if (torn) sec.missing.push_back("measurement: the journal's last line is torn (an interrupted write)");
  s += runs_part(dir);
  if (journal.empty()) return sec;
  // Timeline: position against rig-clock time; a run that resumed starts its clock again.
  Series pos = series("positions", "points", "#2e86c1", 1.6);
  Series resumes = series("resumed", "impulses", "#c0392b", 2.0);
  Series exposure = series("exposures per position", "impulses", "#27ae60", 3.0);
  Series took = series("rig-clock time per position", "points", "#2e86c1", 1.4);
  Series lower = series("exposure time per position", "points", "#e67e22", 1.4);
  double offset = 0.0, last_end = 0.0, total = 0.0, exposure_total = 0.0;
  int runs = 1;
  std::map<double, int> exposures_used;
  for (std::size_t k = 0; k < journal.size(); ++k) {
    const Json& r = journal[k];
    const double start = number_or_nan(at(r, {"clock_start_s"})), end = number_or_nan(at(r, {"clock_end_s"}));
    if (k > 0 && std::isfinite(start) && start + offset < last_end - 1e-9) {
      offset = last_end;  // the clock restarted: a resumed run
      ++runs;
      resumes.x.push_back(start + offset);
      resumes.y.push_back(number_or_nan(at(r, {"angle_deg"})));
    }
    pos.x.push_back(start + offset);
    pos.y.push_back(number_or_nan(at(r, {"angle_deg"})));
    if (std::isfinite(end)) last_end = end + offset;
    const double index = number_or_nan(at(r, {"index"}));
    const Json* ex = at(r, {"exposures_s"});
    double ex_sum = 0.0;
    int ex_count = 0;
    if (ex && ex->is_array())
      for (const Json& e : *ex) {
        ex_sum += number_or_nan(&e);
        ++ex_count;
      }
    exposure.x.push_back(index);
    exposure.y.push_back(ex_count);
    ++exposures_used[ex_count];
    took.x.push_back(index);
    took.y.push_back(end - start);
    lower.x.push_back(index);
    lower.y.push_back(ex_sum);
    if (std::isfinite(end - start)) total += end - start;
    exposure_total += ex_sum;
  }
  Plot timeline = make_plot("Journal timeline", "rig-clock time (s)", "light angle (deg)");
  timeline.series = {pos};
  if (!resumes.x.empty()) timeline.series.push_back(resumes);
  s += plot_figure(timeline, fmt::format("Each finished position at the time it started on the rig clock; {} run{}{}.",
                                         runs, runs == 1 ? "" : "s",
                                         runs > 1 ? " (red: where a resumed run took over)" : ""));
  Plot ex = make_plot("Exposures per position", "position index", "exposures");
  ex.series = {exposure};
  ex.settings = {"yrange [0:*]"};
  std::string used;
  for (const auto& [n, count] : exposures_used) used += fmt::format("{}{} positions with {}", used.empty() ? "" : ", ", count, n);
  s += plot_figure(ex, "Exposures taken per position (adaptive bracketing takes fewer where the sphere is dark): " +
                           esc(used) + ".");
  Plot t = make_plot("Time per position", "position index", "time (s)");
  t.log_y = true;
  t.series = {took, lower};
  s += plot_figure(t, fmt::format("Rig-clock time each position took (blue) against the exposure time it needed "
                                  "(orange). Sweep: {} s of rig time, of which {} s exposure ({}%); the rest is table "
                                  "motion, settling and readout.",
                                  num(total, 4), num(exposure_total, 4),
                                  num(total > 0 ? 100.0 * exposure_total / total : std::nan(""), 3)));
  return sec;
}

}  // namespace paintlab::report
