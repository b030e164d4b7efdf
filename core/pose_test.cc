#include "core/pose.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;
using testing::PoseNear;

const Pose kCamFromScreen(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                          Eigen::Vector3d(10, -20, 1500));

TEST(Pose, InverseUndoesAndComposesToIdentity) {
  const Eigen::Vector3d point_in_screen(100, 50, -1000);
  const Eigen::Vector3d point_in_cam = kCamFromScreen * point_in_screen;
  EXPECT_THAT(kCamFromScreen.Inverse() * point_in_cam, EigenNear(point_in_screen, 1e-9));
  EXPECT_THAT(kCamFromScreen * kCamFromScreen.Inverse(), PoseNear(Pose::Identity(), 1e-12, 1e-9));
}

TEST(Pose, CompositionAppliesRightToLeft) {
  const Pose screen_from_world(Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY())),
                               Eigen::Vector3d(0, 0, -1000));
  const Eigen::Vector3d x_in_world(1, 2, 3);
  EXPECT_THAT((kCamFromScreen * screen_from_world) * x_in_world,
              EigenNear(kCamFromScreen * (screen_from_world * x_in_world), 1e-9));
}

TEST(Pose, SourceOriginInTargetIsTheTranslation) {
  // The camera centre (origin of the camera frame) in the screen frame.
  const Pose screen_from_cam = kCamFromScreen.Inverse();
  EXPECT_THAT(screen_from_cam * Eigen::Vector3d::Zero(), EigenNear(screen_from_cam.translation, 1e-12));
  EXPECT_THAT(kCamFromScreen * screen_from_cam.translation, EigenNear(Eigen::Vector3d::Zero(), 1e-9));
}

TEST(Pose, MrcalRtRoundTripAndAQuarterTurn) {
  EXPECT_THAT(Pose::FromRt(kCamFromScreen.ToRt()), PoseNear(kCamFromScreen, 1e-12, 1e-9));
  // rt = (0, 0, pi/2, 1, 2, 3): x -> y, then shifted.
  const Pose p = Pose::FromRt({0, 0, M_PI / 2, 1, 2, 3});
  EXPECT_THAT(p * Eigen::Vector3d(1, 0, 0), EigenNear(Eigen::Vector3d(1, 3, 3), 1e-12));
  EXPECT_THAT(Pose::FromRt({0, 0, 0, 4, 5, 6}).translation, EigenNear(Eigen::Vector3d(4, 5, 6), 0));
}

TEST(Pose, MatcherFailsOnRotationOrTranslation) {
  Pose moved = kCamFromScreen;
  moved.translation.x() += 0.01;
  EXPECT_THAT(moved, ::testing::Not(PoseNear(kCamFromScreen, 1e-9, 1e-3)));
  EXPECT_THAT(moved, PoseNear(kCamFromScreen, 1e-9, 0.02));
  const Pose turned(kCamFromScreen.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(1e-4, Eigen::Vector3d::UnitX())),
                    kCamFromScreen.translation);
  EXPECT_THAT(turned, ::testing::Not(PoseNear(kCamFromScreen, 1e-5, 1)));
  EXPECT_NEAR(RotationDistanceRad(turned, kCamFromScreen), 1e-4, 1e-10);
}

}  // namespace
}  // namespace curvecheck
