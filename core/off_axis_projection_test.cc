#include "core/off_axis_projection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;

Eigen::Vector3d Corner(const Monitor& m, double u, double v) { return SurfacePointFromUv(m, {u, v}); }

// Thesis Eq 4.5/4.6: for viewpoints between the top and bottom edges, the four corners of the display (which
// lie in the near plane) map to the corners of clip space, at depth 0.
TEST(OffAxisProjection, CornersMapToClipCorners) {
  for (const Monitor& m : {MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000),
                           MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0)}) {
    for (const Eigen::Vector3d& off : {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(-200, 100, 900)}) {
      const Eigen::Vector3d o = ScreenCentreInScreen(m) + off;
      const OffAxisFrustum fr = MakeOffAxisFrustum(m, o);
      EXPECT_FALSE(fr.vertical_extents_widened);
      EXPECT_THAT(fr.NdcFromPoint(Corner(m, -1, 1)), EigenNear(Eigen::Vector3d(-1, -1, 0), 1e-12)) << m.name;
      EXPECT_THAT(fr.NdcFromPoint(Corner(m, 1, -1)), EigenNear(Eigen::Vector3d(1, 1, 0), 1e-12)) << m.name;
      EXPECT_NEAR(fr.near_mm, off.z() - m.sagitta_mm(), 1e-9);
      // The far plane maps to depth 1.
      EXPECT_NEAR(fr.NdcFromPoint(o - Eigen::Vector3d(0, 0, fr.far_mm)).z(), 1, 1e-12);
    }
  }
}

// The matrix is a pinhole projection onto the near plane: x_ndc = (2 x_np - (r + l)) / (r - l) where x_np is
// where the ray to the point crosses the near plane, relative to the viewpoint.
TEST(OffAxisProjection, MatrixIsPinholeOntoNearPlane) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const Eigen::Vector3d o(120, -40, -350);
  const OffAxisFrustum fr = MakeOffAxisFrustum(m, o);
  const Eigen::Vector3d p(-300, 77, -1400);
  const Eigen::Vector3d d = p - o;
  const double s = fr.near_mm / -d.z();
  const Eigen::Vector2d np(d.x() * s, d.y() * s);
  const Eigen::Vector3d ndc = fr.NdcFromPoint(p);
  EXPECT_NEAR(ndc.x(), (2 * np.x() - (fr.right_mm + fr.left_mm)) / (fr.right_mm - fr.left_mm), 1e-12);
  EXPECT_NEAR(ndc.y(), (2 * np.y() - (fr.top_mm + fr.bottom_mm)) / (fr.top_mm - fr.bottom_mm), 1e-12);
}

// Thesis 4.2.2: from above or below the screen the corner frustum misses part of the curved surface; the
// widened extents cover every display point, and tightly (the top or bottom of the centre column touches
// +-1). Checked on a dense sampling of the surface for random viewpoints inside and outside the cylinder.
TEST(OffAxisProjection, WidenedExtentsCoverTheWholeSurfaceTightly) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  std::mt19937_64 rng(5);
  int widened = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d o = testing::RandomViewpoint(m, i % 2 == 0, rng);
    if (o.z() - ScreenCentreInScreen(m).z() <= m.sagitta_mm() + 1) continue;  // not coverable linearly
    const OffAxisFrustum fr = MakeOffAxisFrustum(m, o);
    double max_x = 0, max_y = 0;
    for (int iu = 0; iu <= 64; ++iu) {
      for (int iv = 0; iv <= 16; ++iv) {
        const Eigen::Vector3d ndc = fr.NdcFromPoint(SurfacePointFromUv(m, {-1 + iu / 32.0, -1 + iv / 8.0}));
        max_x = std::max(max_x, std::abs(ndc.x()));
        max_y = std::max(max_y, std::abs(ndc.y()));
        EXPECT_GE(ndc.z(), -1e-12);
      }
    }
    EXPECT_LE(max_x, 1 + 1e-12);
    EXPECT_LE(max_y, 1 + 1e-12);
    EXPECT_NEAR(max_x, 1, 1e-12);  // the vertical edges of the display bound x exactly
    EXPECT_NEAR(max_y, 1, 1e-12);  // a corner or the centre column's end bounds y exactly
    if (fr.vertical_extents_widened) ++widened;
    if (std::abs(o.y()) > 0.5 * m.height_mm) {
      EXPECT_TRUE(fr.vertical_extents_widened);
    }
  }
  EXPECT_GT(widened, 20);
}

TEST(OffAxisProjection, RefusesViewpointsInsideTheChordPlane) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  // 100 mm in front of the centre, but the corners stand 174 mm in front of it: FOV > 180 deg.
  try {
    MakeOffAxisFrustum(m, {0, 0, -900});
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("cannot cover a field of view of 180 deg"));
  }
  EXPECT_THROW(MakeOffAxisFrustum(m, {0, 0, -1100}), Error);  // behind the screen
}

}  // namespace
}  // namespace curvecheck
