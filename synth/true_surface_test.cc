// The ray intersection alone: a ray from the camera through a point of the true surface lands at that point's
// surface coordinates (the tracer's geometry agrees with the truth's), on leaned, bumped, moved panels.
#include "synth/true_surface.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "core/camera_model.h"
#include "synth/scene.h"

namespace curvecheck::synth_internal {
namespace {

SyntheticScene PlacedScene(double radius_mm) {
  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("49 test", 5120, 1440, 49, 1000);
  s.truth.curvature_per_mm = radius_mm > 0 ? 1 / radius_mm : 0;
  s.truth.translation_mm = {3, -2, 5};
  s.truth.rotation_deg = {0.5, -1, 0.3};
  s.truth.lean_deg = 2;
  s.camera = PinholeModel(3000, 2000, 2000);
  s.screen_from_cam.translation = {100, 50, 600};
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, {0, 0, -1000}, Eigen::Vector3d::UnitY());
  return s;
}

// Worst |(u, v) found - (u, v) aimed at| over a grid of the display, rays from the camera to the true points.
double WorstRoundTrip(const SyntheticScene& s) {
  const SurfaceIntersector surface(s, 1.1);
  const Eigen::Matrix3d cam_from_screen = s.screen_from_cam.RotationMatrix().transpose();
  double worst = 0;
  int64_t refined = 0;
  for (double v = -0.95; v <= 0.95; v += 0.19) {
    for (double u = -0.95; u <= 0.95; u += 0.095) {
      const Eigen::Vector3d p = TrueSurfacePointInScreen(s, {u, v});
      const Eigen::Vector3d d = surface.upright_from_cam() * (cam_from_screen * (p - s.screen_from_cam.translation));
      double hit_u = 0, hit_v = 0;
      EXPECT_TRUE(surface.Intersect(d, &refined, &hit_u, &hit_v)) << u << " " << v;
      worst = std::max({worst, std::abs(hit_u - u), std::abs(hit_v - v)});
    }
  }
  return worst;
}

TEST(SurfaceIntersector, RayThroughATrueSurfacePointLandsOnItsSurfaceCoordinates) {
  for (double radius_mm : {1080.0, 0.0}) {
    SyntheticScene s = PlacedScene(radius_mm);
    const double analytic = WorstRoundTrip(s);
    // A bump covering the display (4 sigma support everywhere): every ray is refined onto it.
    s.truth.bumps = {{0.1, -0.2, 0.5, 0.6, 4.0}};
    const double refined = WorstRoundTrip(s);
    std::cout << "radius " << radius_mm << " mm: worst (u, v) error " << analytic << " without bumps, " << refined
              << " on a 4 mm bump\n";
    // Without bumps the hit is the closed-form root (FastAtan within 1e-10 rad); on the bump the fixed-point
    // steps stop after a step below 1e-5, leaving below 1e-6 (synth/true_surface.cc).
    EXPECT_LT(analytic, 1e-9);
    EXPECT_LT(refined, 1e-6);
  }
}

TEST(SurfaceIntersector, RaysAwayFromTheDisplayMissIt) {
  for (double radius_mm : {1080.0, 0.0}) {
    const SyntheticScene s = PlacedScene(radius_mm);
    const SurfaceIntersector surface(s, 1.1);
    const Eigen::Matrix3d cam_from_screen = s.screen_from_cam.RotationMatrix().transpose();
    const auto ray_to = [&](const Eigen::Vector2d& uv) -> Eigen::Vector3d {
      const Eigen::Vector3d p = TrueSurfacePointInScreen(s, uv);
      return surface.upright_from_cam() * (cam_from_screen * (p - s.screen_from_cam.translation));
    };
    int64_t refined = 0;
    double u = 0, v = 0;
    EXPECT_TRUE(surface.Intersect(ray_to({0, 0}), &refined, &u, &v));
    // Backwards: the plane is not behind the camera; the cylinder (the camera is inside it) continues there, far
    // beyond the display's edges (|u| > 1), where the tracer sees the room.
    if (radius_mm == 0) {
      EXPECT_FALSE(surface.Intersect(-ray_to({0, 0}), &refined, &u, &v));
    } else if (surface.Intersect(-ray_to({0, 0}), &refined, &u, &v)) {
      EXPECT_GT(std::abs(u), 1.5);
    }
    // Above the display and its bezel (|v| > max_abs_v) with no bump to refine: a miss.
    EXPECT_FALSE(surface.Intersect(ray_to({0, -1.5}), &refined, &u, &v)) << radius_mm;
    EXPECT_EQ(refined, 0);
  }
}

}  // namespace
}  // namespace curvecheck::synth_internal
