#pragma once
// Intrinsics on the simulated rig (examples/rig-sim.toml: a 50 mm lens at 1.2 m, 10 deg
// field of view): chessboard views rendered through the simulator's true camera and sensor,
// calibrated, compared with the truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "paintlab/calibration/intrinsics.h"
#include "paintlab/sim/scenes.h"
#include "sim_scenes.h"

namespace paintlab::calib::testing {

// Chessboard views of the simulated rig through its true camera and sensor (16-bit raw,
// white at half the full well), calibrated; the corner-noise floor is the RMS distance of
// the found corners from their true projections.
struct SimIntrinsicsRun {
  CameraModel truth;
  IntrinsicsResult result;
  double floor_px = 0.0;
  double seconds = 0.0;
};

inline SimIntrinsicsRun run_sim_intrinsics(const sim::Chessboard& cb, const std::vector<Rigid3>& poses, sim::SimWorld& world) {
  const auto t0 = std::chrono::steady_clock::now();
  SimIntrinsicsRun run;
  run.truth = truth_camera(world);
  const BoardSpec board{cb.cols, cb.rows, cb.square_m};
  sim::PlaneLighting light;
  light.irradiance_w_m2 = world.irradiance_for_fill(0.5, 0.01, cb.white_albedo);
  std::vector<BoardImage> images;
  std::vector<std::vector<Vec2>> truth_corners;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    ImageF radiance = sim::render_chessboard(world.camera(), cb, poses[k], light, 16, 1, 0);
    sim::ExposureSettings es;
    es.exposure_s = 0.01;
    es.output_bits = 16;
    es.frame_index = k;
    images.push_back({"view" + std::to_string(k), world.sensor().expose(radiance, es), 16});
    truth_corners.push_back(sim::project_points(world.camera(), poses[k], cb.corners()));
  }
  IntrinsicsOptions o;
  o.initial_focal_px = world.config().nominal.focal_length_mm / (world.config().nominal.pixel_size_um * 1e-3);
  run.result = calibrate_intrinsics(images, board, o);
  double ss = 0;
  int n = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (!run.result.views[k].used) continue;
    auto t = truth_corners[k];
    const auto& c = run.result.views[k].corners_px;
    if ((c.front() - t.front()).norm() > (c.front() - t.back()).norm()) std::reverse(t.begin(), t.end());
    for (std::size_t i = 0; i < t.size(); ++i, ++n) ss += (c[i] - t[i]).squaredNorm();
  }
  run.floor_px = std::sqrt(ss / n);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const IntrinsicsResult& r = run.result;
  const CameraModel& truth = run.truth;
  std::printf("sim intrinsics (%d views of %dx%d): RMS %.4f px, corner-noise floor %.4f px (ratio %.2f); fx %.2f +- %.2f "
              "(true %.2f, %+.4f %%), fy %.2f +- %.2f (%+.4f %%), cx %.2f +- %.2f (true %.2f, %+.2f px), cy %.2f +- %.2f "
              "(true %.2f, %+.2f px); %.1f s\n",
              r.views_used, cb.cols, cb.rows, r.rms_px, run.floor_px, r.rms_px / run.floor_px, r.camera.fx(), r.std.fx,
              truth.fx(), 100 * (r.camera.fx() / truth.fx() - 1), r.camera.fy(), r.std.fy,
              100 * (r.camera.fy() / truth.fy() - 1), r.camera.cx(), r.std.cx, truth.cx(), r.camera.cx() - truth.cx(),
              r.camera.cy(), r.std.cy, truth.cy(), r.camera.cy() - truth.cy(), run.seconds);
  return run;
}

}  // namespace paintlab::calib::testing
