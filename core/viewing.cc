#include "core/viewing.h"

#include <cmath>

#include "core/math_util.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));  // accurate for small and large angles alike
}

}  // namespace

ViewingGeometry DescribeViewing(const Monitor& m, const Eigen::Vector3d& o) {
  CheckViewpoint(m, o, "viewpoint");
  ViewingGeometry g;
  g.distance_to_centre_mm = (o - ScreenCentreInScreen(m)).norm();
  g.front_clearance_mm = FrontClearanceMm(m, o);

  // Horizontal: sum the signed azimuth steps along the centre line, so that sweeps beyond 180 deg
  // (viewpoints close inside a strongly curved screen) are measured without wrapping. Each step is far
  // below pi, so the sum equals the unwrapped difference of the end azimuths exactly.
  constexpr int kSteps = 2048;
  double sweep = 0;
  Eigen::Vector2d prev;
  for (int i = 0; i <= kSteps; ++i) {
    const Eigen::Vector3d d = SurfacePointFromUv(m, {-1.0 + 2.0 * i / kSteps, 0.0}) - o;
    const Eigen::Vector2d xz(d.x(), d.z());
    if (i > 0) sweep += std::atan2(prev.x() * xz.y() - prev.y() * xz.x(), prev.dot(xz));
    prev = xz;
  }
  g.horizontal_fov_deg = std::abs(sweep) * kDegPerRad;

  const Eigen::Vector3d top = SurfacePointFromUv(m, {0.0, -1.0}) - o;
  const Eigen::Vector3d bottom = SurfacePointFromUv(m, {0.0, 1.0}) - o;
  g.vertical_fov_deg = AngleBetween(top, bottom) * kDegPerRad;

  // One pixel centred on the screen centre: from u = -1/Nx to +1/Nx, v = -1/Ny to +1/Ny.
  const double du = 1.0 / m.width_px, dv = 1.0 / m.height_px;
  const double ax = AngleBetween(SurfacePointFromUv(m, {-du, 0.0}) - o, SurfacePointFromUv(m, {du, 0.0}) - o);
  const double ay = AngleBetween(SurfacePointFromUv(m, {0.0, -dv}) - o, SurfacePointFromUv(m, {0.0, dv}) - o);
  g.pixels_per_degree_horizontal = 1.0 / (ax * kDegPerRad);
  g.pixels_per_degree_vertical = 1.0 / (ay * kDegPerRad);
  return g;
}

}  // namespace curvecheck
