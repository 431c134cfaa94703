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

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

struct CheckArgs {
  std::string rig;
  bool capture = false;
  std::string images;
  bool json = false;
};

}  // namespace

void register_check_commands(CLI::App& app) {
  auto a = std::make_shared<CheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "check", "Is the rig fit to measure? Every check against rig.toml's tolerances (writes calib/check.json; exit 1 on a failure)");
  cmd->add_option("--rig", a->rig, "rig.toml")->required();
  cmd->add_flag("--capture", a->capture, "also check the rig live through its devices (sphere, focus, LED, drift)");
  cmd->add_option("--images", a->images, "live evidence from a folder: sphere/, light/, drift/, reference/");
  cmd->add_flag("--json", a->json, "print check.json instead of the table");
  on_run(cmd, [a] {
    if (a->capture && !a->images.empty()) throw UsageError("check: give --capture or --images, not both");
    const RigConfig rig = load_rig(a->rig);
    {
      // check.json goes into the calibration folder: never over the live images, never into a
      // session or library.
      fit::OutputGuard guard;
      guard.input("--rig", a->rig);
      if (!a->images.empty() && fs::is_directory(a->images)) {
        std::error_code ec;
        for (auto it = fs::recursive_directory_iterator(a->images, ec); !ec && it != fs::recursive_directory_iterator();
             it.increment(ec))
          if (it->is_regular_file(ec)) guard.input("--images", it->path());
      }
      OutputSpec report("--rig", rig.calibration_dir / calib::kCheckFile);
      report.beside = a->rig;
      report.create_parents = true;
      guard.output(report).check();
    }
    const calib::RigCalibration cal = calib::RigCalibration::load(rig);
    acq::LiveCheck live;
    std::unique_ptr<CalibSession> session;
    if (a->capture) {
      session = std::make_unique<CalibSession>(open_calib_session(rig, 0.0));
      acq::CalibrationRig capture = session->capture_rig();
      live = acq::capture_live_check(capture, cal, rig);
      live.evidence.devices = session->serials;
    } else if (!a->images.empty()) {
      acq::Linearizer linearizer(load_radiometry(rig));
      live = acq::live_check_from_images(a->images, cal, rig, linearizer);
    }

    calib::CheckReport report = calib::run_checks(rig, cal, live.evidence);
    report.items.insert(report.items.end(), live.failed.begin(), live.failed.end());
    fs::create_directories(rig.calibration_dir);
    report.save(rig.calibration_dir / calib::kCheckFile);
    if (a->json)
      say(report.to_json().dump(2));
    else
      say(report.table());
    return report.passed() ? kExitOk : kExitFailed;
  });
}

}  // namespace paintlab::app
