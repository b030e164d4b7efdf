#include "core/correction.h"

#include <cmath>

#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck {

void PatternPlane::Check(const std::string& where) const {
  if (!origin_in_screen.allFinite() || !x_axis_in_screen.allFinite() || !y_axis_in_screen.allFinite()) {
    throw Error(where, "pattern plane has non-finite values", "give finite origin and axes");
  }
  if (std::abs(x_axis_in_screen.norm() - 1) > 1e-9 || std::abs(y_axis_in_screen.norm() - 1) > 1e-9 ||
      std::abs(x_axis_in_screen.dot(y_axis_in_screen)) > 1e-9) {
    throw Error(where, "pattern plane axes are not orthonormal", "give unit, perpendicular x and y axes");
  }
}

PatternPlane TangentPlaneAtCentre(const Monitor& m) {
  PatternPlane plane;
  plane.origin_in_screen = ScreenCentreInScreen(m);
  return plane;
}

std::optional<Eigen::Vector2d> PatternFromDisplayPx(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                    const PatternPlane& plane, const Eigen::Vector2d& display_px) {
  const Eigen::Vector3d surface = SurfacePointFromUv(m, UvFromDisplayPx(m, display_px));
  // Ray viewpoint + t (surface - viewpoint) meets the plane where n . (p - origin) = 0.
  // Both differences are formed before any product so that a far-away screen frame origin (huge R) does
  // not cost precision.
  const Eigen::Vector3d dir = surface - viewpoint;
  const Eigen::Vector3d n = plane.Normal();
  const double denom = n.dot(dir);
  if (denom == 0) return std::nullopt;
  const double t = n.dot(plane.origin_in_screen - viewpoint) / denom;
  if (!(t > 0) || !std::isfinite(t)) return std::nullopt;
  const Eigen::Vector3d rel = (viewpoint - plane.origin_in_screen) + t * dir;
  return Eigen::Vector2d(rel.dot(plane.x_axis_in_screen), rel.dot(plane.y_axis_in_screen));
}

std::optional<Eigen::Vector2d> DisplayPxFromPoint(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                  const Eigen::Vector3d& point_in_screen) {
  const std::optional<SurfaceHit> hit = IntersectSurface(m, viewpoint, point_in_screen - viewpoint);
  if (!hit) return std::nullopt;
  return DisplayPxFromUv(m, hit->uv);
}

std::optional<Eigen::Vector2d> DisplayPxFromPattern(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                    const PatternPlane& plane, const Eigen::Vector2d& pattern_mm) {
  // The ray toward the pattern point; written as (origin - viewpoint) + offsets in the plane so that the
  // direction keeps full precision when the frame origin is far away.
  const Eigen::Vector3d dir = (plane.origin_in_screen - viewpoint) + pattern_mm.x() * plane.x_axis_in_screen +
                              pattern_mm.y() * plane.y_axis_in_screen;
  const std::optional<SurfaceHit> hit = IntersectSurface(m, viewpoint, dir);
  if (!hit) return std::nullopt;
  return DisplayPxFromUv(m, hit->uv);
}

}  // namespace curvecheck
