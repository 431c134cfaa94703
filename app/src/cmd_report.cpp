// paintlab report INPUT --out FILE.html   (docs/reports.md)
#include <fmt/format.h>

#include <chrono>

#include "cli.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/report/report.h"

namespace paintlab::app {
namespace {

constexpr const char* kReportHelp =
    "One self-contained HTML page (images and plots inline, nothing loaded from the network; prints) of a "
    "calibration folder, a session, a fit.json or a demo folder: calibration residuals, intrinsics, response, dark "
    "and flat maps, sphere, LEDs and colour chart; the rig check with what to do about each failure; the "
    "measurement's journal; the fit's parameters, residuals and measured-against-fitted curves; colour; "
    "provenance with checksums. A part whose files are missing says so. Exit 0 written, 2 bad input (nothing "
    "written). docs/reports.md.";

struct ReportArgs {
  std::string input;
  std::string out;
  std::string title;
  std::string rig;
};

int run_report(const ReportArgs& a) {
  fit::OutputGuard().input("INPUT", a.input).input("--rig", a.rig).output({"--out", a.out}).check();
  const auto t0 = std::chrono::steady_clock::now();
  const report::ReportInput in = report::classify_input(a.input);
  say(fmt::format("report: {} {}", report::to_string(in.kind), in.path.string()));
  report::ReportOptions o;
  o.title = a.title;
  o.rig = a.rig;
  const report::Report r = report::make_report(in, o);
  write_file_atomic(a.out, r.html);
  for (const std::string& f : r.failing) say("  failing: " + f);
  for (const std::string& m : r.missing) say("  missing: " + m);
  say(fmt::format("wrote {} ({:.1f} kB, sections: {}) in {:.1f} s", a.out, r.html.size() / 1024.0,
                  fmt::join(r.sections, ", "),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
  return kExitOk;
}

}  // namespace

void register_report_commands(CLI::App& app) {
  auto [cmd, a] = add_command<ReportArgs>(&app, "report", kReportHelp, run_report);
  cmd->add_option("INPUT", a->input, "a calibration folder, a session folder, a fit.json or a demo folder")->required();
  cmd->add_option("--out", a->out, "the HTML file to write")->required();
  cmd->add_option("--title", a->title, "page title (default: the paint or folder and the kind of input)");
  cmd->add_option("--rig", a->rig,
                  "the rig file whose nominal geometry the calibration is compared with (default: a demo's rig.toml, "
                  "the one a session names, or rig.toml beside a calibration folder it names)");
}

}  // namespace paintlab::app
