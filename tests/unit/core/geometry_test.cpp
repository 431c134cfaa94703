#include <gtest/gtest.h>

#include "paintlab/core/geometry.h"
#include "test_util.h"

using namespace paintlab;

TEST(Geometry, AngleWrapping) {
  EXPECT_NEAR(wrap_360(-10), 350, 1e-12);
  EXPECT_NEAR(wrap_360(720), 0, 1e-12);
  EXPECT_NEAR(angle_diff_deg(359, 1), -2, 1e-12);
  EXPECT_NEAR(angle_diff_deg(1, 359), 2, 1e-12);
  EXPECT_NEAR(wrap_pi(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(angle_between(Vec3(1, 0, 0), Vec3(0, 1, 0)), kPi / 2, 1e-15);
  EXPECT_NEAR(angle_between(Vec3(1, 0, 0), Vec3(1, 1e-9, 0)), 1e-9, 1e-20);
}

TEST(Geometry, LookAtPutsTargetOnOpticalAxis) {
  Vec3 eye(1.2, 0.0, 0.05), target(0, 0, 0);
  Rigid3 cam_from_rig = look_at(eye, target, Vec3::UnitZ());
  Vec3 t = cam_from_rig * target;
  EXPECT_NEAR(t.x(), 0, 1e-12);
  EXPECT_NEAR(t.y(), 0, 1e-12);
  EXPECT_NEAR(t.z(), (eye - target).norm(), 1e-12);
  // Rig "up" (+z) appears as image "up" (negative camera y).
  Vec3 up = cam_from_rig * Vec3(0, 0, 0.1) - t;
  EXPECT_LT(up.y(), 0);
  EXPECT_NEAR((cam_from_rig.inverse().translation - eye).norm(), 0, 1e-12);
}

TEST(Geometry, FrameFromNormalIsOrthonormal) {
  for (Vec3 n : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 2, 3).normalized(), Vec3(-0.3, 0.1, -0.9).normalized()}) {
    Mat3 f = frame_from_normal(n);
    EXPECT_NEAR((f.transpose() * f - Mat3::Identity()).norm(), 0, 1e-12);
    EXPECT_NEAR((f.col(2) - n).norm(), 0, 1e-15);
    EXPECT_NEAR(f.determinant(), 1.0, 1e-12);
  }
}
