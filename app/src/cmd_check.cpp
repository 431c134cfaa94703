// paintlab check --rig R [--capture | --images DIR] [--json]: is the rig fit to measure?
// Every check against the tolerances of rig.toml, a pass/fail table with what to do, the
// report in calib/check.json; exit 1 when any check fails (docs/calibration.md).
#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "rig_devices.h"
#include "calibrate_support.h"
#include "paintlab/core/input_files.h"
#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/calibration/check.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/rig.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/report/report.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// The commands' descriptions (their --help).
constexpr const char* kCheckHelp =
    "Is the rig fit to measure? Every check against rig.toml's tolerances (writes calib/check.json; exit 1 on a "
    "failure)";

struct CheckArgs {
  std::string rig;
  bool capture = false;
  std::string images;
  bool json = false;
  std::string report;
};

int run_check(const CheckArgs& a) {
  if (a.capture && !a.images.empty()) throw UsageError("check: give --capture or --images, not both");
  const RigConfig rig = load_rig(a.rig);
  // check.json goes into the calibration folder: never over the live images, never into a
  // session or library.
  OutputSpec out("--rig", rig.calibration_dir / calib::kCheckFile);
  out.beside = a.rig;
  out.create_parents = true;
  fit::OutputGuard()
      .input("--rig", a.rig)
      .input_tree("--images", a.images)
      .output(out)
      .output({"--report", a.report})
      .check();

  const calib::RigCalibration cal = calib::RigCalibration::load(rig);
  acq::LiveCheck live;
  std::unique_ptr<CalibSession> session;
  if (a.capture) {
    session = std::make_unique<CalibSession>(open_calib_session(rig, 0.0));
    acq::CalibrationRig capture = session->capture_rig();
    live = acq::capture_live_check(capture, cal, rig);
    live.evidence.devices = session->serials;
  } else if (!a.images.empty()) {
    acq::Linearizer linearizer(load_radiometry(rig));
    live = acq::live_check_from_images(a.images, cal, rig, linearizer);
  }
  calib::CheckReport report = calib::run_checks(rig, cal, live.evidence);
  report.items.insert(report.items.end(), live.failed.begin(), live.failed.end());
  fs::create_directories(rig.calibration_dir);
  report.save(rig.calibration_dir / calib::kCheckFile);
  say(a.json ? report.to_json().dump(2) : report.table());
  if (!a.report.empty()) {
    // The calibration folder's report, failing checks first (written whether the check passed or not).
    paintlab::report::ReportOptions options;
    options.rig = a.rig;
    const paintlab::report::Report page =
        paintlab::report::make_report(paintlab::report::classify_input(rig.calibration_dir), options);
    write_file_atomic(a.report, page.html);
    say(fmt::format("wrote {} (the calibration and this check)", a.report));
  }
  return report.passed() ? kExitOk : kExitFailed;
}

}  // namespace

void register_check_commands(CLI::App& app) {
  auto [cmd, a] = add_command<CheckArgs>(&app, "check", kCheckHelp, run_check);
  cmd->add_option("--rig", a->rig, "rig.toml")->required();
  cmd->add_flag("--capture", a->capture, "also check the rig live through its devices (sphere, focus, LED, drift)");
  cmd->add_option("--images", a->images, "live evidence from a folder: sphere/, light/, drift/, reference/");
  cmd->add_flag("--json", a->json, "print check.json instead of the table");
  cmd->add_option("--report", a->report,
                  "also write an HTML report of the calibration folder and this check (as paintlab report)");
}

}  // namespace paintlab::app
