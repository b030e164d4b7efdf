#include "core/viewing.h"

#include <algorithm>
#include <cmath>

#include "core/flip.h"
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

double NearestSurfaceDistanceMm(const Monitor& m, const Eigen::Vector3d& o) {
  const double v = std::clamp(-2 * o.y() / m.height_mm, -1.0, 1.0);  // y = -v H/2 on the surface
  const double dy = -0.5 * v * m.height_mm - o.y();
  auto horizontal2 = [&](double u) {
    const Eigen::Vector3d p = SurfacePointFromUv(m, {u, 0.0});
    return (p.x() - o.x()) * (p.x() - o.x()) + (p.z() - o.z()) * (p.z() - o.z());
  };
  constexpr int kSteps = 4096;
  int best = 0;
  double best_d2 = horizontal2(-1.0);
  for (int i = 1; i <= kSteps; ++i) {
    const double d2 = horizontal2(-1.0 + 2.0 * i / kSteps);
    if (d2 < best_d2) best_d2 = d2, best = i;
  }
  double lo = -1.0 + 2.0 * std::max(best - 1, 0) / kSteps, hi = -1.0 + 2.0 * std::min(best + 1, kSteps) / kSteps;
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  for (int it = 0; it < 60; ++it) {
    const double a = hi - g * (hi - lo), b = lo + g * (hi - lo);
    if (horizontal2(a) < horizontal2(b)) {
      hi = b;
    } else {
      lo = a;
    }
  }
  const double h2 = std::min(best_d2, horizontal2(0.5 * (lo + hi)));
  return std::sqrt(h2 + dy * dy);
}

double ViewerPixelsPerDegree(const Monitor& m, const Eigen::Vector3d& o) {
  CheckViewpoint(m, o, "viewpoint");
  return FlipPixelsPerDegree(NearestSurfaceDistanceMm(m, o), m.pixel_pitch_mm());
}

}  // namespace curvecheck
