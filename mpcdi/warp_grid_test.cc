// The warp grid against the geometry core by independent paths: the inverse mapping (DisplayPxFromPoint, a ray
// cast onto the cylinder), a flat monitor (identity), a constant deviation (a cylinder of radius R - d), and the
// bilinear interpolation error of the default grid on the issue's 49" 1000R panel.
#include "mpcdi/warp_grid.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <iostream>

#include "core/correction.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/test_util.h"
#include "datasets/monitor_presets.h"

namespace curvecheck {
namespace {

using testing::EigenNear;
using testing::MessageOf;

// The point of the tangent plane (the source image's plane) that source coordinate (u, v) shows.
Eigen::Vector3d TangentPoint(const Monitor& m, const Eigen::Vector2d& uv) {
  return ScreenCentreInScreen(m) + Eigen::Vector3d((uv.x() - 0.5) * m.width_mm, (uv.y() - 0.5) * m.height_mm, 0);
}

TEST(WarpGrid, SamplesInvertTheRayCastOntoTheCylinder) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  for (const Eigen::Vector3d& eye : {Eigen::Vector3d(0, 0, 500), Eigen::Vector3d(150, -80, 300)}) {
    const WarpGrid g = MakeWarpGrid(m, eye, nullptr, 41, 13);
    double worst = 0;
    for (int j = 0; j < g.rows; ++j) {
      for (int i = 0; i < g.cols; ++i) {
        // The ray from the eye toward the plane point the sample reads must land on the sample's display position.
        const auto px = DisplayPxFromPoint(m, eye, TangentPoint(m, g.At(i, j).cast<double>()));
        ASSERT_TRUE(px.has_value());
        worst = std::max(worst, (*px - g.SamplePx(i, j)).norm());
      }
    }
    EXPECT_LT(worst, 2e-3) << "float storage: u to 6e-8, 3e-4 px; eye " << eye.transpose();
  }
}

TEST(WarpGrid, CentreAndEdgesOnTheAxis) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const Eigen::Vector3d eye(0, 0, 500);
  // The display centre shows the source centre; left/right and top/bottom are symmetric.
  EXPECT_THAT(*SourceUvFromDisplayPx(m, eye, nullptr, {2559.5, 719.5}), EigenNear(Eigen::Vector2d(0.5, 0.5), 1e-12));
  const Eigen::Vector2d left = *SourceUvFromDisplayPx(m, eye, nullptr, {-0.5, 719.5});
  const Eigen::Vector2d right = *SourceUvFromDisplayPx(m, eye, nullptr, {5119.5, 719.5});
  EXPECT_NEAR(left.x() + right.x(), 1, 1e-12);
  // The curved edges stand in front of the tangent plane, so the ray through them meets it farther out than
  // the flat W/2: the corrected display reads beyond the source image there (u < 0), which the alpha map masks.
  EXPECT_LT(left.x(), 0);
  const Eigen::Vector2d top = *SourceUvFromDisplayPx(m, eye, nullptr, {2559.5, -0.5});
  EXPECT_NEAR(top.y(), 1, 1e-12) << "the centre column lies in the tangent plane";
}

TEST(WarpGrid, FlatMonitorIsTheIdentity) {
  const Monitor m = LoadMonitor("27in-2560x1440-flat");
  const WarpGrid g = MakeWarpGrid(m, Eigen::Vector3d(300, 100, 700), nullptr, 5, 4);
  for (int j = 0; j < g.rows; ++j) {
    for (int i = 0; i < g.cols; ++i) {
      EXPECT_THAT(g.At(i, j).cast<double>(),
                  EigenNear(Eigen::Vector2d(i / 4.0, 1 - j / 3.0), 1e-7));
    }
  }
  // Sample placement: the outer samples on the display's outer edges; the interpolation reads them there.
  EXPECT_THAT(g.SamplePx(0, 0), EigenNear(Eigen::Vector2d(-0.5, -0.5), 0));
  EXPECT_THAT(g.SamplePx(4, 3), EigenNear(Eigen::Vector2d(2559.5, 1439.5), 0));
  EXPECT_THAT(g.Sample({1279.5, 719.5}), EigenNear(Eigen::Vector2d(0.5, 0.5), 1e-7));
  // Source pixel convention: (u, v) = (0.5, 0.5) is the image centre; v = 1 the top edge.
  EXPECT_THAT(SourcePxFromUv({0.5, 0.5}, 2560, 1440), EigenNear(Eigen::Vector2d(1279.5, 719.5), 1e-12));
  EXPECT_THAT(SourcePxFromUv({0, 1}, 2560, 1440), EigenNear(Eigen::Vector2d(-0.5, -0.5), 1e-12));
  EXPECT_THAT(UvFromSourcePx({-0.5, 1439.5}, 2560, 1440), EigenNear(Eigen::Vector2d(0, 0), 1e-12));
}

TEST(WarpGrid, ConstantDeviationIsACylinderOfSmallerRadius) {
  // d mm toward the viewer everywhere on a cylinder of radius R is the cylinder of radius R - d with the same
  // axis and sector (its arc width W (R - d)/R): the mapping must equal that monitor's, read on the original
  // tangent plane.
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const double d = 7;
  const double r = m.radius_mm();
  const Monitor inner =
      MonitorFromActiveArea("inner", m.width_px, m.height_px, m.width_mm * (r - d) / r, m.height_mm, r - d);
  DeviationMap dev;
  dev.nu = 3;
  dev.nv = 2;
  dev.mm.assign(6, d);
  const Eigen::Vector3d eye(40, 30, 500);
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(0, 0), Eigen::Vector2d(5119, 1439), Eigen::Vector2d(1000, 300)}) {
    const Eigen::Vector2d ab = *PatternFromDisplayPx(inner, eye, TangentPlaneAtCentre(m), px);
    const Eigen::Vector2d expected(ab.x() / m.width_mm + 0.5, ab.y() / m.height_mm + 0.5);
    EXPECT_THAT(*SourceUvFromDisplayPx(m, eye, &dev, px), EigenNear(expected, 1e-12)) << px.transpose();
  }
  // A zero map is the ideal cylinder.
  dev.mm.assign(6, 0);
  EXPECT_THAT(*SourceUvFromDisplayPx(m, eye, &dev, {123, 456}),
              EigenNear(*SourceUvFromDisplayPx(m, eye, nullptr, {123, 456}), 1e-12));
}

TEST(DeviationMap, BilinearBetweenCellCentresAndConstantBeyond) {
  DeviationMap dev;
  dev.nu = 2;
  dev.nv = 2;
  dev.mm = {0, 4, 8, 12};  // centres at u, v = -0.5 and 0.5; v = -0.5 is the top row
  EXPECT_DOUBLE_EQ(dev.At({-0.5, -0.5}), 0);
  EXPECT_DOUBLE_EQ(dev.At({0.5, 0.5}), 12);
  EXPECT_DOUBLE_EQ(dev.At({0, 0}), 6);
  EXPECT_DOUBLE_EQ(dev.At({-1, -1}), 0) << "held constant beyond the outermost centres";
  EXPECT_DOUBLE_EQ(dev.At({1, -1}), 4);
  dev.mm.pop_back();
  EXPECT_THAT(MessageOf([&] { dev.Check("result.json"); }), ::testing::HasSubstr("has 3 values"));
}

TEST(WarpGrid, DefaultGridInterpolatesWithinFiveHundredthsOfAPixel) {
  // The README's figure: the default grid on the issue's 49" 5120x1440 1000R panel, viewpoint 0,0,500 (1.5 m from
  // the screen centre), every pixel.
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const Eigen::Vector3d eye(0, 0, 500);
  const auto [cols, rows] = DefaultWarpGridSize(m);
  EXPECT_EQ(cols, 321);
  EXPECT_EQ(rows, 91);
  const WarpInterpolationError e = MeasureWarpInterpolation(m, eye, nullptr, MakeWarpGrid(m, eye, nullptr, cols, rows), 1);
  std::cout << cols << " x " << rows << ": max " << e.max_px << " rms " << e.rms_px << " display px at "
            << e.worst_display_px.transpose() << " over " << e.pixels << " px\n";
  EXPECT_EQ(e.pixels, 5120 * 1440);
  EXPECT_LT(e.max_px, 0.05);
  // A grid 4x coarser is 16x worse (bilinear error ~ spacing^2): the measure sees the interpolation.
  const WarpInterpolationError coarse =
      MeasureWarpInterpolation(m, eye, nullptr, MakeWarpGrid(m, eye, nullptr, 81, 24), 2);
  std::cout << "81 x 24: max " << coarse.max_px << " rms " << coarse.rms_px << " display px\n";
  EXPECT_GT(coarse.max_px, 8 * e.max_px);
}

TEST(WarpGrid, RefusesBadGridsAndViewpointsTooNear) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  EXPECT_THAT(MessageOf([&] { MakeWarpGrid(m, {0, 0, 500}, nullptr, 1, 10); }), ::testing::HasSubstr("--grid"));
  // 100 mm in front of the centre (z = -900), behind the plane of the curved edges (174 mm in front of it): the
  // rays through the edges run away from the tangent plane, which a planar source image cannot show.
  EXPECT_THAT(MessageOf([&] { MakeWarpGrid(m, {0, 0, -900}, nullptr, 9, 3); }),
              ::testing::HasSubstr("does not meet the plane of the source image"));
}

}  // namespace
}  // namespace curvecheck
