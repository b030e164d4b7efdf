#include "core/viewing.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/math_util.h"

namespace curvecheck {
namespace {

// Thesis chapter 1: a 49" 32:9 screen seen from 50 cm spans about 100 deg flat and about 120 deg with R = 1 m.
TEST(Viewing, ThesisFieldsOfViewFromHalfAMetre) {
  const Monitor flat = MonitorFromDiagonal("49 flat", 5120, 1440, 49, 0);
  const Monitor curved = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const ViewingGeometry gf = DescribeViewing(flat, {0, 0, 500});
  const ViewingGeometry gc = DescribeViewing(curved, {0, 0, -500});
  EXPECT_NEAR(gf.horizontal_fov_deg, 100, 1.0);
  EXPECT_NEAR(gc.horizontal_fov_deg, 120, 1.0);
  // And exactly, from the edge coordinates.
  EXPECT_NEAR(gf.horizontal_fov_deg, 2 * std::atan(0.5 * flat.width_mm / 500) * kDegPerRad, 1e-9);
  const double t = curved.half_sector_rad();
  EXPECT_NEAR(gc.horizontal_fov_deg, 2 * std::atan2(1000 * std::sin(t), 1000 * std::cos(t) - 500) * kDegPerRad, 1e-9);
  EXPECT_NEAR(gf.distance_to_centre_mm, 500, 1e-12);
  EXPECT_NEAR(gc.distance_to_centre_mm, 500, 1e-12);
}

// From the cylinder axis the horizontal FOV is the sector angle 2 theta and the vertical one 2 atan(H/2R).
TEST(Viewing, FromTheAxis) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const ViewingGeometry g = DescribeViewing(m, {0, 0, 0});
  EXPECT_NEAR(g.horizontal_fov_deg, 2 * m.half_sector_rad() * kDegPerRad, 1e-9);
  EXPECT_NEAR(g.vertical_fov_deg, 2 * std::atan(0.5 * m.height_mm / 1000) * kDegPerRad, 1e-9);
  // Every pixel subtends pitch / R radians horizontally from the axis.
  EXPECT_NEAR(g.pixels_per_degree_horizontal, 1000 / m.pixel_pitch_mm() / kDegPerRad, 1e-6);
}

// A field of view beyond 180 deg (close to a strongly curved screen) is measured without wrapping.
TEST(Viewing, WideFieldBeyondHalfCircle) {
  const Monitor m = MonitorFromDiagonal("49 600R", 5120, 1440, 49, 600);  // sector 114 deg
  const ViewingGeometry g = DescribeViewing(m, {0, 0, -550});              // 50 mm from the centre
  const double t = m.half_sector_rad();
  const double expected = 2 * std::atan2(600 * std::sin(t), 600 * std::cos(t) - 550) * kDegPerRad;
  EXPECT_GT(expected, 180);
  EXPECT_NEAR(g.horizontal_fov_deg, expected, 1e-9);
}

TEST(Viewing, PixelsPerDegreeOfA27InchFrom60cm) {
  const Monitor m = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  const ViewingGeometry g = DescribeViewing(m, {0, 0, 600});
  const double expected = 1 / (2 * std::atan(0.5 * m.pixel_pitch_mm() / 600) * kDegPerRad);
  EXPECT_NEAR(g.pixels_per_degree_horizontal, expected, 1e-9);
  EXPECT_NEAR(g.pixels_per_degree_vertical, expected, 1e-9);
  EXPECT_NEAR(expected, 44.9, 0.1);
}

}  // namespace
}  // namespace curvecheck
