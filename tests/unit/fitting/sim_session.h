#pragma once
#include <functional>
// A measurement on the simulated rig for the fitting tests, without the device chain:
// the simulator renders the sphere's radiance (RGB) at each table angle, pixel noise is
// added (relative `noise_rel`, the variance written beside it as an HDR merge does), and
// the frames are written as HDR EXR files (R, G, B, var.*, valid). The calibration
// folder holds the simulator's truth (camera, sphere, LED circle, scale = LED intensity,
// since the frames are radiance), written with the calibration module's own writers.
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "paintlab/acquisition/session.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/rig.h"
#include "paintlab/fitting/extraction.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/world.h"
#include "test_util.h"

namespace paintlab::fit::test_support {

struct SimSessionOptions {
  int width_px = 640;
  int height_px = 480;
  double focal_length_mm = 25.0;
  double start_deg = 0.0, stop_deg = 180.0, step_deg = 2.0;
  double noise_rel = 0.02;
  bool sparkle = true;
  double psf_sigma_px = 0.0;  // the lens blur (Gaussian sigma); the light calibration states it
  // Read noise, as a fraction of the radiance of a white diffuser facing the LED, and the
  // noise floor the merge censors at (in read-noise sigmas): a pixel whose noisy value is
  // below it in any channel is invalid, with infinite variance, as hdr_merge.h writes (its
  // value, below the floor there, a bound). 0: no read noise, every pixel valid.
  double read_noise_white = 0.0;
  double floor_sigmas = 3.0;
  std::uint64_t seed = 1;
  // What renders a position's radiance (the simulator's own render when empty): e.g. a
  // model's render_rig, to measure a rendered paint as the simulated one is.
  std::function<ImageF(const sim::SimWorld&, double angle_deg)> renderer;
};

struct SimSession {
  test::TempDir dir;
  std::vector<HdrFrame> frames;
  std::unique_ptr<sim::SimWorld> world;
  std::filesystem::path calibration_dir() const { return dir.path() / "calib"; }
};

inline sim::SimConfig small_rig(const SimSessionOptions& o) {
  RigGeometry g;
  g.sphere_radius_m = 0.04;
  g.arm_radius_m = 0.6;
  g.camera_distance_m = 1.2;
  g.camera_height_m = 0.05;
  g.focal_length_mm = o.focal_length_mm;
  g.image_width_px = o.width_px;
  g.image_height_px = o.height_px;
  sim::SimConfig c = sim::SimConfig::defaults(g);
  c.seed = o.seed;
  c.camera.psf_sigma_px = o.psf_sigma_px;
  return c;
}

// Writes the simulator's truth as calibration files.
inline void write_truth_calibration(const sim::SimWorld& w, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const Json devices = {{"camera", "SIM"}};
  calib::IntrinsicsResult in;
  in.camera.width_px = w.camera().width();
  in.camera.height_px = w.camera().height();
  in.camera.K = w.K();
  in.camera.dist = w.dist();
  in.provenance = calib::Provenance::make("intrinsics", {}, devices);
  in.save(dir / calib::kCameraFile);
  calib::SphereFit s;
  s.radius_m = w.sphere_radius_m();
  s.centre_cam_m = w.sphere_centre_cam();
  s.edge_sigma_px = w.config().camera.psf_sigma_px;
  s.edge_width_px = 2.563 * s.edge_sigma_px;
  s.provenance = calib::Provenance::make("sphere", {}, devices);
  s.save(dir / calib::kSphereFile);
  // The LED circle in calibration's convention: origin on the table axis at the sphere
  // centre's height, x towards the camera.
  calib::LightCalibration l;
  const Rigid3& cfr = w.cam_from_rig();
  const Vec3 c_rig = w.sphere_centre_rig();
  l.model.axis_cam = cfr.rotation * Vec3::UnitZ();
  l.model.origin_cam = cfr * Vec3(0.0, 0.0, c_rig.z());
  l.model.arm_radius_m = w.config().led.arm_radius_m;
  l.model.arm_height_m = w.config().led.arm_height_m - c_rig.z();
  const Vec3 cam = w.camera().centre_rig();
  l.model.zero_deg = w.config().led.zero_deg - rad_to_deg(std::atan2(cam.y(), cam.x()));
  l.model.profile_exponent = w.config().led.profile_exponent;
  l.blur_sigma_px = w.config().camera.psf_sigma_px;
  l.blur_source = "given";
  l.provenance = calib::Provenance::make("light", {}, devices);
  l.save(dir / calib::kLightFile);
  calib::ScaleCalibration sc;
  sc.scale = w.config().led.intensity_w_sr;  // radiance frames: rate = f I0 E
  sc.profile_exponent = w.config().led.profile_exponent;
  sc.provenance = calib::Provenance::make("scale", {}, devices);
  sc.save(dir / calib::kScaleFile);
}

inline std::unique_ptr<SimSession> make_sim_session(const sim::SimPaint& paint, const SimSessionOptions& o) {
  auto s = std::make_unique<SimSession>();
  s->world = std::make_unique<sim::SimWorld>(small_rig(o));
  s->world->set_paint(paint);
  write_truth_calibration(*s->world, s->calibration_dir());
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  sim::RenderOptions ro;
  ro.mono = false;
  ro.sparkle = o.sparkle;
  std::filesystem::create_directories(s->dir.path() / "hdr");
  const double arm = std::hypot(s->world->config().led.arm_radius_m, s->world->config().led.arm_height_m);
  const double read = o.read_noise_white * s->world->config().led.intensity_w_sr / (std::numbers::pi * arm * arm);
  const double floor = o.floor_sigmas * read;
  int index = 0;
  for (double a = o.start_deg; a <= o.stop_deg + 1e-9; a += o.step_deg, ++index) {
    const ImageF radiance = o.renderer ? o.renderer(*s->world, a) : s->world->render_at(a, true, ro);
    ExrImage exr;
    const char* names[3] = {"R", "G", "B"};
    std::vector<ImageF> value(3, ImageF(radiance.width(), radiance.height())), var = value;
    ImageF valid(radiance.width(), radiance.height(), 1, 1.0f);
    for (int y = 0; y < radiance.height(); ++y)
      for (int x = 0; x < radiance.width(); ++x) {
        bool censored = false;
        for (int c = 0; c < 3; ++c) {
          const double l = radiance.at(x, y, c);
          const double sd = std::hypot(o.noise_rel * l, read);
          const double v = l + sd * gauss(rng);
          value[c].at(x, y) = static_cast<float>(v);
          var[c].at(x, y) = static_cast<float>(sd * sd);
          censored = censored || (read > 0 && v < floor);
        }
        if (censored) {
          valid.at(x, y) = 0.0f;
          for (int c = 0; c < 3; ++c) var[c].at(x, y) = std::numeric_limits<float>::infinity();
        }
      }
    for (int c = 0; c < 3; ++c) exr.add(names[c], std::move(value[c]));
    for (int c = 0; c < 3; ++c) exr.add(std::string("var.") + names[c], std::move(var[c]));
    exr.add("valid", std::move(valid));
    const auto path = s->dir.path() / "hdr" / fmt::format("pos_{:03d}.exr", index);
    write_exr(path, exr);
    s->frames.push_back({path, a});
  }
  return s;
}

// The frames of a simulated sweep as a session folder `dir` (session.json, journal.jsonl,
// hdr/pos_XXX.exr), as paintlab measure leaves it, for sample `sample`; the plan holds
// `extra_planned` more positions than were measured. `colour_space`: what session.json says
// the radiance is (the simulator renders linear sRGB; empty: camera RGB, a mono session's).
inline void write_session_folder(const SimSession& sim, const std::filesystem::path& dir, const std::string& sample,
                                 int extra_planned = 0, const std::string& colour_space = "") {
  acq::SessionManifest m;
  m.sample = sample;
  m.options.colour_space = colour_space;
  m.exposures_s = {0.01};
  for (const HdrFrame& f : sim.frames) m.angles_deg.push_back(f.angle_deg);
  for (int k = 0; k < extra_planned; ++k) m.angles_deg.push_back(m.angles_deg.back() + 1.0);
  const acq::SessionDir session = acq::SessionDir::create(dir, m);
  for (std::size_t i = 0; i < sim.frames.size(); ++i) {
    const int index = static_cast<int>(i);
    std::filesystem::copy_file(sim.frames[i].path, session.hdr_path(index));
    acq::JournalEntry e;
    e.index = index;
    e.angle_deg = e.angle_read_deg = sim.frames[i].angle_deg;
    e.file = acq::SessionDir::hdr_name(index);
    e.sha256 = sha256_file(session.hdr_path(index));
    session.journal().append(e);
  }
}

}  // namespace paintlab::fit::test_support
