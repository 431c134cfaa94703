#include "paintlab/calibration/check.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>

#include "paintlab/core/error.h"
#include "paintlab/core/version.h"

namespace paintlab::calib {

bool CheckReport::passed() const { return failures() == 0; }

int CheckReport::failures() const {
  return static_cast<int>(std::count_if(items.begin(), items.end(), [](const CheckItem& i) { return !i.pass; }));
}

const CheckItem* CheckReport::find(const std::string& id) const {
  for (const auto& i : items)
    if (i.id == id) return &i;
  return nullptr;
}

namespace {

std::string number(double v) {
  if (!std::isfinite(v)) return "-";
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= 1000 || a < 0.001) return fmt::format("{:.3g}", v);
  return fmt::format("{:.4g}", v);
}

std::string limit_text(const CheckItem& i) {
  switch (i.limit) {
    case Limit::AtMost:
      return "<= " + number(i.tolerance) + (i.unit.empty() ? "" : " " + i.unit);
    case Limit::AtLeast:
      return ">= " + number(i.tolerance) + (i.unit.empty() ? "" : " " + i.unit);
    case Limit::Required:
      return "required";
  }
  return "";
}

const char* limit_name(Limit l) {
  switch (l) {
    case Limit::AtMost:
      return "at_most";
    case Limit::AtLeast:
      return "at_least";
    case Limit::Required:
      return "required";
  }
  return "";
}

}  // namespace

std::string CheckReport::table() const {
  std::size_t wid = 5, wval = 5, wtol = 9;
  std::vector<std::string> vals;
  for (const auto& i : items) {
    wid = std::max(wid, i.id.size());
    std::string v = i.limit == Limit::Required ? (i.pass ? "yes" : "no")
                                                : number(i.value) + (i.unit.empty() ? "" : " " + i.unit);
    vals.push_back(v);
    wval = std::max(wval, v.size());
    wtol = std::max(wtol, limit_text(i).size());
  }
  std::string out = fmt::format("{:<{}}  {:<{}}  {:<{}}  {}\n", "check", wid, "value", wval, "tolerance", wtol, "verdict");
  for (std::size_t k = 0; k < items.size(); ++k) {
    const CheckItem& i = items[k];
    out += fmt::format("{:<{}}  {:<{}}  {:<{}}  {}", i.id, wid, vals[k], wval, limit_text(i), wtol, i.pass ? "pass" : "FAIL");
    if (!i.pass) {
      if (!i.detail.empty()) out += "  (" + i.detail + ")";
      out += "\n" + std::string(wid + 2, ' ') + "-> " + i.action;
    }
    out += "\n";
  }
  out += fmt::format("{}: {} of {} checks passed", passed() ? "RIG OK" : "RIG NOT FIT TO MEASURE",
                     static_cast<int>(items.size()) - failures(), items.size());
  return out;
}

Json CheckReport::to_json() const {
  Json arr = Json::array();
  for (const auto& i : items) {
    Json o = {{"id", i.id}, {"what", i.what}, {"limit", limit_name(i.limit)}, {"pass", i.pass}, {"action", i.action}};
    o["value"] = std::isfinite(i.value) ? Json(i.value) : Json(nullptr);
    o["tolerance"] = std::isfinite(i.tolerance) ? Json(i.tolerance) : Json(nullptr);
    if (!i.unit.empty()) o["unit"] = i.unit;
    if (!i.detail.empty()) o["detail"] = i.detail;
    arr.push_back(o);
  }
  return {{"rig", rig},
          {"date", date},
          {"software_version", software_version()},
          {"passed", passed()},
          {"failures", failures()},
          {"checks", arr}};
}

void CheckReport::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

double intensity_drift_rel(const std::vector<ImageF>& repeated, const CameraModel& camera, const SphereFit& sphere) {
  if (repeated.size() < 2) throw UsageError("LED drift: at least two repeated images are needed");
  const Vec2 c = camera.project(sphere.centre_cam_m);
  const double rho = camera.fx() * sphere.radius_m / sphere.centre_cam_m.norm();
  std::vector<std::pair<int, int>> pix;
  for (int y = static_cast<int>(c.y() - rho); y <= static_cast<int>(c.y() + rho); ++y)
    for (int x = static_cast<int>(c.x() - rho); x <= static_cast<int>(c.x() + rho); ++x)
      if (x >= 0 && y >= 0 && x < camera.width_px && y < camera.height_px && (Vec2(x, y) - c).norm() < 0.8 * rho)
        pix.emplace_back(x, y);
  if (pix.empty()) throw CalibrationError("LED drift: the sphere is not in the image");
  auto mean = [&](const ImageF& im) {
    if (im.width() != camera.width_px || im.height() != camera.height_px)
      throw DataError("LED drift: the images must be the camera's size");
    double s = 0;
    for (auto [x, y] : pix) s += im.at(x, y);
    return s / static_cast<double>(pix.size());
  };
  const double m0 = mean(repeated.front());
  if (!(m0 > 0)) throw CalibrationError("LED drift: the first image is dark (is the LED on?)");
  double worst = 0;
  for (std::size_t i = 1; i < repeated.size(); ++i) worst = std::max(worst, std::abs(mean(repeated[i]) / m0 - 1.0));
  return worst;
}

CheckReport run_checks(const RigConfig& rig, const RigCalibration& cal, const LiveEvidence& live) {
  const Tolerances& tol = rig.tolerances;
  CheckReport rep;
  rep.rig = rig.name;
  rep.date = utc_timestamp();
  auto add = [&rep](CheckItem i) {
    switch (i.limit) {
      case Limit::AtMost:
        i.pass = std::isfinite(i.value) && i.value <= i.tolerance;
        break;
      case Limit::AtLeast:
        i.pass = std::isfinite(i.value) && i.value >= i.tolerance;
        break;
      case Limit::Required:
        break;  // set by the caller
    }
    rep.items.push_back(std::move(i));
  };
  auto item = [](std::string id, std::string what, Limit limit, double value, double tolerance, std::string unit,
                 std::string action) {
    CheckItem i;
    i.id = std::move(id);
    i.what = std::move(what);
    i.limit = limit;
    i.value = value;
    i.tolerance = tolerance;
    i.unit = std::move(unit);
    i.action = std::move(action);
    return i;
  };

  // --- files: present, fresh, same devices ---
  Json reference_devices = live.devices.is_object() && !live.devices.empty() ? live.devices : Json::object();
  std::string reference_from = reference_devices.empty() ? "" : "the connected devices";
  for (const std::string& name : standard_files()) {
    const CalibrationFile& f = cal.files().at(name);
    const std::string step = calibrate_step_for(name);
    CheckItem present = item(step + ".file", name + " present", Limit::Required, NAN, NAN, "",
                             "run `paintlab calibrate " + step + " --rig " + rig.file.filename().string() + "`");
    present.pass = f.present;
    if (!f.present) present.detail = f.path.string() + " does not exist";
    add(present);
    if (!f.present) continue;
    CheckItem age = item(step + ".age_days", name + " age", Limit::AtMost, NAN, tol.calibration_max_age_days, "days",
                         "stale: recalibrate with `paintlab calibrate " + step + "`");
    if (f.provenance) {
      age.value = f.provenance->age_days();
      if (!std::isfinite(age.value)) age.detail = "its date '" + f.provenance->date + "' is not readable";
      else if (age.value < -1.0 / 24.0) {
        age.detail = "dated in the future (" + f.provenance->date + "): the clock was wrong";
        age.value = NAN;
      }
    } else {
      age.detail = "no provenance block";
    }
    add(age);
    if (f.provenance && !f.provenance->devices.empty()) {
      if (reference_devices.empty()) {
        reference_devices = f.provenance->devices;
        reference_from = name;
      }
    }
  }
  {
    CheckItem dev = item("devices.serials", "calibrations made with the rig's devices", Limit::Required, NAN, NAN, "",
                         "a device was exchanged since: recalibrate every step with `paintlab calibrate all`");
    dev.pass = true;
    // (device, recorded serial) -> files
    std::map<std::pair<std::string, std::string>, std::vector<std::string>> differing;
    for (const std::string& name : standard_files()) {
      const CalibrationFile& f = cal.files().at(name);
      if (!f.present || !f.provenance) continue;
      for (auto it = reference_devices.begin(); it != reference_devices.end(); ++it) {
        if (!f.provenance->devices.contains(it.key())) continue;
        if (f.provenance->devices.at(it.key()) != it.value()) {
          dev.pass = false;
          differing[{it.key(), f.provenance->devices.at(it.key()).dump()}].push_back(name);
        }
      }
    }
    std::string mismatch;
    for (const auto& [k, names] : differing) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      mismatch += fmt::format("{}{} {} in {} (vs {} in {})", mismatch.empty() ? "" : "; ", k.first, k.second, list,
                              reference_devices.at(k.first).dump(), reference_from);
    }
    dev.detail = dev.pass ? (reference_devices.empty() ? "no device serials recorded" : "") : mismatch;
    add(dev);
  }

  // --- recorded figures ---
  if (cal.intrinsics()) {
    const auto& in = *cal.intrinsics();
    add(item("intrinsics.rms_px", "chessboard reprojection RMS", Limit::AtMost, in.rms_px, tol.reprojection_rms_px, "px",
             "retake the chessboard views (flat board, sharp, whole board in view, tilts up to 40 deg) and run "
             "`paintlab calibrate intrinsics`"));
    add(item("intrinsics.views", "chessboard views used", Limit::AtLeast, in.views_used, tol.min_views, "",
             "take more chessboard views (see camera.json for the dropped ones and why)"));
  }
  if (cal.response()) {
    CheckItem i = item("response.linearity", "response linearity error after linearisation", Limit::AtMost,
                       cal.response()->report.linearity_error_rel, tol.response_error_rel, "",
                       "redo the exposure stack (static scene, no flicker, exposures spanning the range) and run "
                       "`paintlab calibrate response`");
    add(i);
  }
  if (cal.dark()) {
    const DarkFrame& d = *cal.dark();
    add(item("dark.hot_fraction", "hot pixels", Limit::AtMost, d.hot_fraction(), tol.hot_pixel_frac, "",
             "cool the camera down / check the sensor; take new dark frames"));
    add(item("dark.level", "mean dark level / full scale", Limit::AtMost,
             d.mean_bias_dn / (std::ldexp(1.0, d.bit_depth) - 1.0), tol.dark_level_frac, "",
             "lens cap on? light leak? check the camera's black-level setting"));
  }
  if (cal.flat()) {
    add(item("flat.corner_ratio", "darkest / brightest image corner of the flat field", Limit::AtLeast,
             cal.flat()->corner_ratio, tol.flat_min_ratio, "",
             "clean the lens, check the diffuser is uniform, open the aperture less; redo the flat field"));
  }
  if (cal.sphere()) {
    const auto& s = *cal.sphere();
    add(item("sphere.fit_rms_px", "silhouette fit residual", Limit::AtMost, s.rms_px, tol.sphere_fit_rms_px, "px",
             "the silhouette is not a clean sphere outline: dust, a scratch, the holder in view, or glare; clean and "
             "run `paintlab calibrate sphere`"));
    add(item("sphere.edge_width_px", "silhouette edge width (10-90 %)", Limit::AtMost, s.edge_width_px, tol.edge_width_px,
             "px", "refocus the lens on the sphere, then recalibrate (intrinsics and sphere)"));
  }
  if (cal.light()) {
    const auto& l = *cal.light();
    add(item("light.residual_deg", "largest highlight residual from the LED circle", Limit::AtMost, l.max_deg,
             tol.light_angle_deg, "deg",
             "the LED is loose or the table wobbles: fix the arm, then run `paintlab calibrate light`"));
  }
  if (cal.scale()) {
    const auto& s = *cal.scale();
    add(item("scale.uncertainty", "uncertainty of the absolute scale", Limit::AtMost, s.uncertainty_rel,
             tol.scale_error_rel, "", "LED unstable or stray light: check the LED, darken the room, run `paintlab calibrate scale`"));
    add(item("scale.saturated", "saturated reference pixels", Limit::AtMost, s.saturated_frac, tol.saturated_frac, "",
             "the reference was over-exposed: run `paintlab calibrate scale` with a shorter exposure"));
  }

  if (cal.colour()) {
    const ColourCalibration& c = *cal.colour();
    const std::string redo = "`paintlab calibrate colour --rig " + rig.file.filename().string() + " --images CHART.exr`";
    CheckItem age = item("colour.age_days", std::string(kColourFile) + " age", Limit::AtMost, c.provenance.age_days(),
                         tol.calibration_max_age_days, "days", "stale: photograph the chart again and run " + redo);
    if (!std::isfinite(age.value)) age.detail = "its date '" + c.provenance.date + "' is not readable";
    add(age);
    add(item("colour.mean_de00", "mean CIEDE2000 over the chart's patches", Limit::AtMost, c.mean_de00,
             tol.colour_mean_de00, "",
             "light the chart evenly without glare, expose it unclipped, check the reference file is your chart's, then "
             "run " + redo + " (or --model root-polynomial-2)"));
    add(item("colour.max_de00", "CIEDE2000 of the worst patch (" + c.worst_patch + ")", Limit::AtMost, c.max_de00,
             tol.colour_max_de00, "", "look at that patch: dirty, scratched, in a reflection or clipped? Then run " + redo));
  }

  // --- live evidence ---
  if (live.sphere) {
    const auto& s = *live.sphere;
    if (cal.sphere()) {
      CheckItem shift = item("sphere.shift_mm", "sphere centre moved since sphere.json", Limit::AtMost,
                             (s.centre_cam_m - cal.sphere()->centre_cam_m).norm() * 1e3, tol.sphere_shift_mm, "mm",
                             "the sphere is not where it was calibrated: seat it in its holder, or run `paintlab calibrate "
                             "sphere` (and light) if the holder moved");
      const Vec3 d = (s.centre_cam_m - cal.sphere()->centre_cam_m) * 1e3;
      shift.detail = fmt::format("moved by ({:+.2f}, {:+.2f}, {:+.2f}) mm in the camera frame", d.x(), d.y(), d.z());
      add(shift);
    }
    add(item("sphere.live_edge_width_px", "silhouette edge width now (focus)", Limit::AtMost, s.edge_width_px,
             tol.edge_width_px, "px", "the image is blurred: refocus the lens (then recalibrate intrinsics and sphere)"));
    add(item("sphere.live_fit_rms_px", "silhouette fit residual now", Limit::AtMost, s.rms_px, tol.sphere_fit_rms_px, "px",
             "the silhouette is not clean now: dust, glare or something in front of the sphere"));
  }
  if (!live.highlights.empty() && cal.light()) {
    LightModel m = cal.light()->model;
    double worst = 0;
    int found = 0;
    std::string where;
    for (Highlight h : live.highlights) {
      if (!h.found) continue;
      ++found;
      highlight_residual(m, &h);
      if (h.residual_deg > worst) {
        worst = h.residual_deg;
        where = fmt::format("worst at table angle {:g} deg: azimuth off by {:+.3f} deg", h.table_angle_deg, h.azimuth_error_deg);
      }
    }
    CheckItem i = item("light.live_angle_deg", "highlights now against light.json", Limit::AtMost, found ? worst : NAN,
                       tol.light_angle_deg, "deg",
                       "the LED is not where light.json says: tighten the arm / re-home the table, then run `paintlab "
                       "calibrate light`");
    i.detail = found ? where : "no highlight found on the sphere";
    add(i);
  }
  if (live.drift_rel)
    add(item("light.drift", "LED intensity change during the check", Limit::AtMost, *live.drift_rel, tol.light_drift_rel,
             "", "the LED output drifts: let it warm up, check its driver current and connections"));
  if (live.reference_saturated_frac)
    add(item("scale.live_saturated", "saturated reference pixels now", Limit::AtMost, *live.reference_saturated_frac,
             tol.saturated_frac, "", "shorten the exposure of the reference capture"));
  return rep;
}

}  // namespace paintlab::calib
