// Intrinsics on the simulated rig's long lens with a dense view-filling board: the
// principal point within 0.5 px (labelled `slow`: 24 full-size views of 450 corners).
#include <gtest/gtest.h>

#include "sim_intrinsics.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using namespace paintlab::calib::testing;

// The principal point of the 50 mm lens within 0.5 px: a dense board (25x18 inner corners
// of 6 mm) filling 70-95 % of the view, 24 views.
TEST(IntrinsicsSim, DenseViewFillingBoardPutsThePrincipalPointWithinHalfAPixel) {
  sim::SimWorld world(sim_rig_config());
  sim::Chessboard cb;
  cb.cols = 25;
  cb.rows = 18;
  cb.square_m = 0.006;
  const auto poses = view_filling_board_poses(world.camera(), cb, 24, world.config().seed);
  const SimIntrinsicsRun run = run_sim_intrinsics(cb, poses, world);
  const IntrinsicsResult& r = run.result;
  ASSERT_EQ(r.views_used, 24);
  EXPECT_LE(r.rms_px, 1.2 * run.floor_px);
  EXPECT_THAT(r.camera.fx(), test::NearRel(run.truth.fx(), 0.001));
  EXPECT_THAT(r.camera.fy(), test::NearRel(run.truth.fy(), 0.001));
  EXPECT_NEAR(r.camera.cx(), run.truth.cx(), 0.5);
  EXPECT_NEAR(r.camera.cy(), run.truth.cy(), 0.5);
  // The reported uncertainty says so too (and is not vanishingly optimistic).
  EXPECT_LT(r.std.cx, 0.5);
  EXPECT_LT(r.std.cy, 0.5);
  EXPECT_NEAR(r.camera.cx(), run.truth.cx(), 3.0 * r.std.cx);
  EXPECT_NEAR(r.camera.cy(), run.truth.cy(), 3.0 * r.std.cy);
}
