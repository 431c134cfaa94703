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
#include "output_guard.h"
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

// A live step that could not produce its evidence becomes a failed check of its own.
calib::CheckItem failed_item(const std::string& id, const std::string& what, const std::string& detail,
                             const std::string& action) {
  calib::CheckItem i;
  i.id = id;
  i.what = what;
  i.limit = calib::Limit::Required;
  i.pass = false;
  i.detail = detail;
  i.action = action;
  return i;
}

double saturated_on_sphere(const Shot& s, const calib::CameraModel& cam, const calib::SphereFit& sphere) {
  if (s.saturated.empty()) return 0.0;
  long long n = 0, sat = 0;
  for (int y = 0; y < s.saturated.height(); ++y)
    for (int x = 0; x < s.saturated.width(); ++x) {
      if (!calib::intersect_sphere(cam.ray(Vec2(x, y)), sphere.centre_cam_m, sphere.radius_m)) continue;
      ++n;
      sat += s.saturated.at(x, y);
    }
  return n ? static_cast<double>(sat) / static_cast<double>(n) : 0.0;
}

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
      OutputGuard guard;
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
    calib::LiveEvidence live;
    std::vector<calib::CheckItem> extra;
    const bool geometry = cal.intrinsics() && cal.sphere();
    const calib::SphereOptions sphere_opt = [&] {
      calib::SphereOptions o;
      o.radius_m = rig.geometry.sphere_radius_m;
      return o;
    }();

    auto fit_live_sphere = [&](const std::vector<Shot>& shots) {
      std::vector<calib::SphereImage> im;
      for (const auto& s : shots) im.push_back({s.name, s.rate});
      try {
        live.sphere = calib::fit_sphere(im, cal.camera(), sphere_opt);
      } catch (const CalibrationError& e) {
        extra.push_back(failed_item("sphere.live", "sphere silhouette now", e.what(),
                                    "the sphere is missing, unlit or out of view: mount it and check the LED"));
      }
    };
    auto find_live_highlights = [&](const std::vector<Shot>& shots) {
      for (const auto& s : shots) {
        if (!s.table_angle_deg) throw UsageError("check: " + s.file.string() + ": no table angle in the file name");
        calib::HighlightImage h{*s.table_angle_deg, s.name, s.rate};
        for (std::size_t i = 0; i < s.saturated.size(); ++i)
          if (s.saturated.values()[i]) h.pixels.values()[i] = std::numeric_limits<float>::infinity();
        h.saturated_at = std::numeric_limits<double>::infinity();
        // The blur light.json's highlights were fitted with (from the highlights themselves).
        calib::LightOptions lo;
        if (cal.light() && cal.light()->blur_source == "highlights") lo.blur_sigma_px = cal.light()->blur_sigma_px;
        live.highlights.push_back(calib::find_highlight(h, cal.camera(), *cal.sphere(), rig.geometry, lo));
      }
    };

    std::unique_ptr<CalibSession> session;
    if (a->capture) {
      session = std::make_unique<CalibSession>(open_calib_session(rig, 0.0));
      live.devices = session->serials;
      if (!geometry) {
        extra.push_back(failed_item("live", "live checks", "camera.json and sphere.json are needed first",
                                    "run `paintlab calibrate all --rig " + a->rig + "`"));
      } else {
        CalibSession& s = *session;
        s.stage->mount(Target::WhiteReference);
        Shot first = capture_shot(s, "check", "drift_start", 0.0, true, 0.7, 0.9999);
        live.reference_saturated_frac = saturated_on_sphere(first, cal.camera(), *cal.sphere());
        std::vector<Shot> side;
        for (double angle : {90.0, 270.0})
          side.push_back(capture_shot(s, "check", fmt::format("sphere_angle{:g}", angle), angle, true, 0.7, 0.999));
        fit_live_sphere(side);
        if (cal.light()) {
          s.stage->mount(Target::GlossySphere);
          std::vector<Shot> hl;
          for (double angle : {-60.0, 0.0, 60.0})
            hl.push_back(capture_shot(s, "check", fmt::format("light_angle{:g}", angle), angle, true, 0.8, 1.0));
          find_live_highlights(hl);
          s.stage->mount(Target::WhiteReference);
        }
        Shot last = capture_shot(s, "check", "drift_end", 0.0, true, 0.7, 0.9999, first.exposure_s);
        live.drift_rel = calib::intensity_drift_rel({first.rate, last.rate}, cal.camera(), *cal.sphere());
        s.stage->mount(Target::Sample);
      }
    } else if (!a->images.empty()) {
      const fs::path dir = a->images;
      if (!geometry)
        throw CalibrationError("check --images: camera.json and sphere.json are needed to read the live images");
      acq::Linearizer linearizer(load_radiometry(rig));
      auto shots_in = [&](const char* sub) {
        std::vector<Shot> v;
        if (fs::is_directory(dir / sub))
          for (const auto& p : expand_input_files({(dir / sub).string()}, "--images", kCalibrationImageExtensions))
            v.push_back(acq::load_shot(p, linearizer));
        return v;
      };
      if (auto v = shots_in("sphere"); !v.empty()) fit_live_sphere(v);
      if (auto v = shots_in("light"); !v.empty() && cal.light()) find_live_highlights(v);
      if (auto v = shots_in("drift"); v.size() >= 2) {
        std::vector<ImageF> rates;
        for (const auto& s : v) rates.push_back(s.rate);
        live.drift_rel = calib::intensity_drift_rel(rates, cal.camera(), *cal.sphere());
      }
      if (auto v = shots_in("reference"); !v.empty()) {
        double worst = 0;
        for (const auto& s : v) worst = std::max(worst, saturated_on_sphere(s, cal.camera(), *cal.sphere()));
        live.reference_saturated_frac = worst;
      }
    }

    calib::CheckReport report = calib::run_checks(rig, cal, live);
    report.items.insert(report.items.end(), extra.begin(), extra.end());
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
