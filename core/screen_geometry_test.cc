#include "core/screen_geometry.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/correction.h"
#include "core/error.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;

Monitor Default1000R() { return MonitorFromDiagonal("49 1000R", 5120, 1440, 49.0, 1000.0); }

// The surface point is thesis Eq 4.1 written directly in the screen frame.
TEST(ScreenGeometry, SurfacePointIsThesisEquation41) {
  const Monitor m = Default1000R();
  const double R = 1000, H = m.height_mm, theta = m.half_sector_rad();
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector2d uv(uni(rng), uni(rng));
    const Eigen::Vector3d expected(std::sin(uv.x() * theta) * R, -0.5 * uv.y() * H, -std::cos(uv.x() * theta) * R);
    EXPECT_THAT(SurfacePointFromUv(m, uv), EigenNear(expected, 1e-9));
    // The normal points to the axis (0, y, 0) and is unit length.
    const Eigen::Vector3d n = SurfaceNormalFromUv(m, uv);
    EXPECT_NEAR(n.norm(), 1, 1e-15);
    const Eigen::Vector3d to_axis = Eigen::Vector3d(0, expected.y(), 0) - expected;
    EXPECT_THAT(n, EigenNear(to_axis.normalized(), 1e-12));
  }
  EXPECT_THAT(ScreenCentreInScreen(m), EigenNear(Eigen::Vector3d(0, 0, -1000), 0));
}

TEST(ScreenGeometry, PixelConventionEdgesAndCentre) {
  const Monitor m = Default1000R();
  EXPECT_THAT(UvFromDisplayPx(m, {-0.5, -0.5}), EigenNear(Eigen::Vector2d(-1, -1), 1e-15));
  EXPECT_THAT(UvFromDisplayPx(m, {5119.5, 1439.5}), EigenNear(Eigen::Vector2d(1, 1), 1e-15));
  EXPECT_THAT(UvFromDisplayPx(m, {2559.5, 719.5}), EigenNear(Eigen::Vector2d(0, 0), 1e-15));
  // Row 0 is the top of the screen: v = -1 -> y = +H/2.
  EXPECT_GT(SurfacePointFromUv(m, UvFromDisplayPx(m, {0, 0})).y(), 0);
}

// display px -> (u, v) -> surface point -> (u, v) -> display px, to 1e-9 px; cylinders and flat.
TEST(ScreenGeometry, RoundTripPxUvSurface) {
  std::mt19937_64 rng(2);
  for (const Monitor& m : {Default1000R(), MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0),
                           MonitorFromDiagonal("55 1000R", 3840, 2160, 55, 1000)}) {
    std::uniform_real_distribution<double> px(-0.5, m.width_px - 0.5), py(-0.5, m.height_px - 0.5);
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector2d p(px(rng), py(rng));
      const Eigen::Vector3d s = SurfacePointFromUv(m, UvFromDisplayPx(m, p));
      EXPECT_THAT(DisplayPxFromUv(m, UvFromSurfacePoint(m, s)), EigenNear(p, 1e-9)) << m.name;
    }
  }
}

// From random viewpoints inside and outside the cylinder, the ray toward a surface point must hit exactly
// that point (the far side, not the near side of the circle), to 1e-9 mm and 1e-9 px.
TEST(ScreenGeometry, RayHitsTheFarSideFromInsideAndOutside) {
  const Monitor m = Default1000R();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> px(-0.5, m.width_px - 0.5), py(-0.5, m.height_px - 0.5);
  for (bool inside : {true, false}) {
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector3d o = testing::RandomViewpoint(m, inside, rng);
      for (int j = 0; j < 10; ++j) {
        const Eigen::Vector2d p(px(rng), py(rng));
        const Eigen::Vector3d s = SurfacePointFromUv(m, UvFromDisplayPx(m, p));
        const auto hit = IntersectSurface(m, o, (s - o) * 0.37);  // any positive scale of the direction
        ASSERT_TRUE(hit.has_value());
        EXPECT_TRUE(hit->on_display);
        EXPECT_THAT(hit->point_in_screen, EigenNear(s, 1e-9));
        EXPECT_THAT(DisplayPxFromUv(m, hit->uv), EigenNear(p, 1e-9));
        EXPECT_NEAR(hit->distance, 1 / 0.37, 1e-9);
      }
    }
  }
}

TEST(ScreenGeometry, RayMissesAndBackwardRays) {
  const Monitor m = Default1000R();
  // From the axis looking away from the screen (+z) the ray still exits the cylinder, behind the viewer,
  // outside the active area.
  auto back = IntersectSurface(m, {0, 0, 0}, {0, 0, 1});
  ASSERT_TRUE(back.has_value());
  EXPECT_FALSE(back->on_display);
  EXPECT_THAT(back->point_in_screen, EigenNear(Eigen::Vector3d(0, 0, 1000), 1e-9));
  // From outside the cylinder, a ray passing beside it misses.
  EXPECT_FALSE(IntersectSurface(m, {0, 0, 2000}, {1, 0, 0}).has_value());
  // A flat screen is not met by rays going away from it or parallel to it.
  const Monitor flat = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  EXPECT_FALSE(IntersectSurface(flat, {0, 0, 500}, {0, 0, 1}).has_value());
  EXPECT_FALSE(IntersectSurface(flat, {0, 0, 500}, {1, 0, 0}).has_value());
  auto hit = IntersectSurface(flat, {10, 20, 500}, {0, 0, -2});
  ASSERT_TRUE(hit.has_value());
  EXPECT_THAT(hit->point_in_screen, EigenNear(Eigen::Vector3d(10, 20, 0), 1e-12));
  EXPECT_NEAR(hit->distance, 250, 1e-12);
}

TEST(ScreenGeometry, FrontClearanceAndViewpointChecks) {
  const Monitor m = Default1000R();
  // On the axis every display point is R away along its normal.
  EXPECT_NEAR(FrontClearanceMm(m, {0, 0, 0}), 1000, 1e-9);
  EXPECT_NEAR(FrontClearanceMm(m, {0, 123, 0}), 1000, 1e-9);  // independent of height
  // On the centre line 500 mm from the screen: the centre is the closest facing point.
  EXPECT_NEAR(FrontClearanceMm(m, {0, 0, -500}), 500, 1e-9);
  EXPECT_NO_THROW(CheckViewpoint(m, {0, 0, -500}, "--viewpoint"));
  // Behind the screen, on it, and far off to the side where the edge is seen from behind.
  EXPECT_THROW(CheckViewpoint(m, {0, 0, -1200}, "--viewpoint"), Error);
  EXPECT_THROW(CheckViewpoint(m, SurfacePointFromUv(m, {0.3, 0.2}), "--viewpoint"), Error);
  EXPECT_THROW(CheckViewpoint(m, {3000, 0, -900}, "--viewpoint"), Error);
  EXPECT_THROW(CheckViewpoint(m, {0, 0, std::nan("")}, "--viewpoint"), Error);
  const Monitor flat = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  EXPECT_NEAR(FrontClearanceMm(flat, {100, 50, 600}), 600, 1e-12);
  EXPECT_THROW(CheckViewpoint(flat, {0, 0, 0}, "--viewpoint"), Error);
  EXPECT_THROW(CheckViewpoint(flat, {0, 0, -10}, "--viewpoint"), Error);
  try {
    CheckViewpoint(m, {0, 0, -1200}, "--viewpoint");
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("--viewpoint: viewpoint (0, 0, -1200) mm is on or behind"));
  }
  // Farther than 1 km from the screen centre (issue 17: 1e160 mm printed an infinite distance): refused with the
  // span the screen would have (1198 mm at 1e160 mm: 6.9e-156 deg); 1 km itself is accepted.
  EXPECT_NO_THROW(CheckViewpoint(m, ScreenCentreInScreen(m) + Eigen::Vector3d(0, 0, kMaxViewpointDistanceMm), "-v"));
  EXPECT_THROW(CheckViewpoint(m, ScreenCentreInScreen(m) + Eigen::Vector3d(0, 0, 1.001e6), "-v"), Error);
  EXPECT_THROW(CheckViewpoint(flat, {1e6, 0, 1e3}, "-v"), Error);
  try {
    CheckViewpoint(m, {0, 0, 1e160}, "--viewpoint");
    ADD_FAILURE() << "accepted a viewpoint 1e160 mm away";
  } catch (const Error& e) {
    EXPECT_EQ(e.where(), "--viewpoint");
    EXPECT_THAT(e.problem(), ::testing::HasSubstr("is 1e+160 mm from the screen centre, beyond 1 km (1e6 mm), where "
                                                  "this 1198 mm wide screen spans 6.9e-156 deg"));
  }
}

}  // namespace
}  // namespace curvecheck

namespace curvecheck {
namespace {

// A viewer D mm in front of the screen centre along its normal, offset (x, y) across it. Analytic: the centre of a
// cylinder of radius R is (0, 0, -R) with normal +z, so the viewpoint is (x, y, D - R); for a flat screen the
// centre is the origin: (x, y, D). Checked also against the surface's own point and normal at (u, v) = (0, 0).
TEST(ScreenGeometry, ViewpointFromScreenCentreIsDAlongTheNormalPlusTheOffset) {
  const Monitor r1000 = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const Monitor r1900 = MonitorFromDiagonal("34 1900R", 3440, 1440, 34, 1900);
  const Monitor flat = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  using V3 = Eigen::Vector3d;
  EXPECT_THAT(ViewpointFromScreenCentre(r1000, 600, {0, 0}), testing::EigenNear(V3(0, 0, -400), 1e-12));
  // The example: --viewpoint 0,0,600 is 2.5 m from a 1900R screen; --distance-mm 600 is 600 mm.
  EXPECT_THAT(ViewpointFromScreenCentre(r1900, 600, {0, 0}), testing::EigenNear(V3(0, 0, -1300), 1e-12));
  EXPECT_NEAR((V3(0, 0, 600) - ScreenCentreInScreen(r1900)).norm(), 2500, 1e-9);
  EXPECT_THAT(ViewpointFromScreenCentre(flat, 600, {0, 0}), testing::EigenNear(V3(0, 0, 600), 1e-12));
  EXPECT_THAT(ViewpointFromScreenCentre(r1000, 750, {120, -40}), testing::EigenNear(V3(120, -40, -250), 1e-12));
  EXPECT_THAT(ViewpointFromScreenCentre(flat, 750, {120, -40}), testing::EigenNear(V3(120, -40, 750), 1e-12));
  for (const Monitor* m : {&r1000, &r1900, &flat}) {
    const V3 centre = SurfacePointFromUv(*m, {0, 0});
    const V3 normal = SurfaceNormalFromUv(*m, {0, 0});
    const V3 v = ViewpointFromScreenCentre(*m, 750, {0, 0});
    EXPECT_THAT(v, testing::EigenNear(V3(centre + 750 * normal), 1e-9)) << m->name;
    // With an offset: still 750 mm along the normal, and sqrt(750^2 + 120^2 + 40^2) from the centre.
    const V3 w = ViewpointFromScreenCentre(*m, 750, {120, -40});
    EXPECT_NEAR((w - centre).dot(normal), 750, 1e-9) << m->name;
    EXPECT_NEAR((w - centre).norm(), std::sqrt(750.0 * 750 + 120 * 120 + 40 * 40), 1e-9) << m->name;
  }
}

}  // namespace
}  // namespace curvecheck
