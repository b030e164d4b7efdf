#include "core/correction.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/screen_geometry.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;

// display px -> pattern -> display px (1e-9 px) and pattern -> display px -> pattern (1e-9 mm), from random
// viewpoints inside and outside the cylinder, on curved and flat monitors.
TEST(Correction, RoundTripsFromRandomViewpoints) {
  std::mt19937_64 rng(11);
  for (const Monitor& m : {MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000),
                           MonitorFromDiagonal("34 1900R", 3440, 1440, 34, 1900),
                           MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0)}) {
    const PatternPlane plane = TangentPlaneAtCentre(m);
    std::uniform_real_distribution<double> px(-0.5, m.width_px - 0.5), py(-0.5, m.height_px - 0.5);
    for (bool inside : {true, false}) {
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector3d o = testing::RandomViewpoint(m, inside, rng);
        for (int j = 0; j < 10; ++j) {
          const Eigen::Vector2d p(px(rng), py(rng));
          const auto pattern = PatternFromDisplayPx(m, o, plane, p);
          if (!pattern) continue;  // the plane is behind or parallel to this ray (rare grazing views)
          const auto back = DisplayPxFromPattern(m, o, plane, *pattern);
          ASSERT_TRUE(back.has_value());
          EXPECT_THAT(*back, EigenNear(p, 1e-9)) << m.name << " inside=" << inside;
          const auto again = PatternFromDisplayPx(m, o, plane, *back);
          ASSERT_TRUE(again.has_value());
          EXPECT_THAT(*again, EigenNear(*pattern, 1e-9));
        }
      }
    }
  }
}

// The defining property: viewpoint, surface point of the pixel and pattern point are collinear.
TEST(Correction, ViewpointSurfaceAndPatternPointAreCollinear) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  PatternPlane plane;  // a tilted plane 200 mm behind the centre
  plane.origin_in_screen = {30, -20, -1200};
  plane.x_axis_in_screen = Eigen::Vector3d(1, 0, 0.2).normalized();
  plane.y_axis_in_screen = Eigen::Vector3d(0, 1, 0.1).normalized();
  plane.y_axis_in_screen =
      (plane.y_axis_in_screen - plane.y_axis_in_screen.dot(plane.x_axis_in_screen) * plane.x_axis_in_screen)
          .normalized();
  const Eigen::Vector3d o(150, 80, -300);
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(5119, 1439), Eigen::Vector2d(1234.5, 700)}) {
    const Eigen::Vector3d s = SurfacePointFromUv(m, UvFromDisplayPx(m, p));
    const Eigen::Vector3d q = plane.PointInScreen(*PatternFromDisplayPx(m, o, plane, p));
    EXPECT_NEAR((s - o).normalized().cross((q - o).normalized()).norm(), 0, 1e-12);
    EXPECT_GT((s - o).dot(q - o), 0);  // same side, in front of the viewpoint
  }
}

TEST(Correction, CentredViewpointMapsCentreToPatternOrigin) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const auto c = PatternFromDisplayPx(m, {0, 0, 500}, TangentPlaneAtCentre(m), {2559.5, 719.5});
  EXPECT_THAT(*c, EigenNear(Eigen::Vector2d(0, 0), 1e-12));
  // Symmetric pixels map to mirrored pattern points.
  const auto l = PatternFromDisplayPx(m, {0, 0, 500}, TangentPlaneAtCentre(m), {100, 719.5});
  const auto r = PatternFromDisplayPx(m, {0, 0, 500}, TangentPlaneAtCentre(m), {5019, 719.5});
  EXPECT_NEAR(l->x(), -r->x(), 1e-9);
  // On a curved screen the edges stand in front of the tangent plane: the pattern is stretched outward.
  const double pitch = m.pixel_pitch_mm();
  EXPECT_GT(std::abs(r->x()), (5019 + 0.5 - 2560) * pitch);
}

// On a flat monitor with the default plane the pattern is the screen itself, whatever the viewpoint.
TEST(Correction, FlatMonitorIsTheIdentityMapping) {
  const Monitor m = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  const double pitch = m.pixel_pitch_mm();
  for (const Eigen::Vector3d& o : {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(-400, 300, 250)}) {
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(2000.25, 37.5)}) {
      const Eigen::Vector2d expected((p.x() + 0.5) * pitch - 0.5 * m.width_mm, 0.5 * m.height_mm - (p.y() + 0.5) * pitch);
      EXPECT_THAT(*PatternFromDisplayPx(m, o, TangentPlaneAtCentre(m), p), EigenNear(expected, 1e-9));
    }
  }
}

// A flat monitor is the R -> infinity limit of the cylinder. Viewpoints are placed the same way relative to
// the screen centre (exact in floating point: integers). The two differ physically by the sagitta
// (W/2)^2 / (2R), 1.8e-4 mm at R = 1e9 mm for a 49" panel, which moves a feature seen at ~50 deg by ~1e-3
// display px; so the test checks (a) surface points agree in x, y to 1e-6 px, (b) the mapping difference
// falls as 1/R (first order in the sagitta, no numerical floor), (c) it is below 1e-6 px by R = 1e13 mm.
TEST(Correction, FlatIsTheLimitOfTheCylinder) {
  const Monitor flat = MonitorFromDiagonal("49 flat", 5120, 1440, 49, 0);
  const double pitch = flat.pixel_pitch_mm();
  const std::vector<Eigen::Vector3d> offsets = {{0, 0, 500}, {-300, 120, 800}, {250, -200, 400}};
  auto max_difference_px = [&](double radius_mm) {
    const Monitor curved = MonitorFromDiagonal("49 R", 5120, 1440, 49, radius_mm);
    double worst = 0, worst_xy = 0;
    for (const Eigen::Vector3d& off : offsets) {
      const Eigen::Vector3d o_curved = ScreenCentreInScreen(curved) + off, o_flat = off;
      for (double a = -560; a <= 560; a += 70) {
        for (double b = -160; b <= 160; b += 40) {
          const auto pc = DisplayPxFromPattern(curved, o_curved, TangentPlaneAtCentre(curved), {a, b});
          const auto pf = DisplayPxFromPattern(flat, o_flat, TangentPlaneAtCentre(flat), {a, b});
          worst = std::max(worst, (*pc - *pf).norm());
          const Eigen::Vector2d uv = UvFromDisplayPx(flat, *pf);
          const Eigen::Vector3d sc = SurfacePointFromUv(curved, uv) - ScreenCentreInScreen(curved);
          const Eigen::Vector3d sf = SurfacePointFromUv(flat, uv);
          worst_xy = std::max(worst_xy, (sc - sf).head<2>().norm() / pitch);
        }
      }
    }
    EXPECT_LT(worst_xy, 1e-6) << "R = " << radius_mm;
    return worst;
  };
  const double d9 = max_difference_px(1e9), d10 = max_difference_px(1e10), d13 = max_difference_px(1e13);
  EXPECT_GT(d9, 1e-5);  // the sagitta is real at 1e9 mm...
  EXPECT_LT(d9, 3e-3);
  EXPECT_NEAR(d10 * 1e10 / (d9 * 1e9), 1.0, 0.01);  // ...and shrinks exactly as 1/R
  EXPECT_LT(d13, 1e-6);
}

}  // namespace
}  // namespace curvecheck
