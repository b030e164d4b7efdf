// Geometry of the ideal screen surface in the screen frame (architecture.md, "Conventions"):
// origin on the cylinder axis at the height of the screen's vertical centre, x right, y up, +z toward the
// viewer, screen centre at (0, 0, -R). A flat monitor has no axis; its screen frame has the origin at the
// screen centre, so that the plane z = 0 is the screen. Units are mm and radians.
//
// Display pixel (i, j) has its centre at (i, j); u = 2 (x + 0.5)/Nx - 1, v = 2 (y + 0.5)/Ny - 1, so u, v run
// from -1 to 1 edge to edge. The surface point is P = (R sin(u theta), -v H/2, -R cos(u theta)) (thesis Eq 4.1).
//
// Internally the formulas are written relative to the screen centre with the curvature kappa = 1/R, so they
// stay exact and free of cancellation as kappa -> 0 and a flat monitor is the limit of the cylinder.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>

#include "core/monitor.h"

namespace curvecheck {

// The screen centre, (0, 0, -R) for a cylinder and the origin for a flat monitor.
Eigen::Vector3d ScreenCentreInScreen(const Monitor& m);

// The viewpoint (screen frame) of a viewer `distance_mm` from the screen centre along the screen's normal there
// (+z), moved across by `offset_mm` (x right, y up, parallel to the screen's tangent plane at the centre): the
// screen centre + (x, y, distance). This is how a user measures a viewing position (`--distance-mm`, `--offset-mm`);
// the frame's origin is on the cylinder axis, R behind the centre, so for 1000R, 600 mm in front of the centre
// is z = -400. Its distance from the centre is sqrt(x^2 + y^2 + distance^2). Does not check the viewpoint.
Eigen::Vector3d ViewpointFromScreenCentre(const Monitor& m, double distance_mm, const Eigen::Vector2d& offset_mm);

// Display pixel coordinates <-> normalized surface coordinates (u, v), both -1..1 edge to edge.
Eigen::Vector2d UvFromDisplayPx(const Monitor& m, const Eigen::Vector2d& display_px);
Eigen::Vector2d DisplayPxFromUv(const Monitor& m, const Eigen::Vector2d& uv);

// (u, v) -> point of the ideal surface (thesis Eq 4.1; any u with |u theta| < pi is on the full cylinder).
Eigen::Vector3d SurfacePointFromUv(const Monitor& m, const Eigen::Vector2d& uv);
// Unit surface normal at (u, v), pointing to the viewer side (toward the axis for a cylinder).
Eigen::Vector3d SurfaceNormalFromUv(const Monitor& m, const Eigen::Vector2d& uv);
// Inverse of SurfacePointFromUv for points on the surface; points off it are projected radially (along
// the normal) onto it first.
Eigen::Vector2d UvFromSurfacePoint(const Monitor& m, const Eigen::Vector3d& point_in_screen);

struct SurfaceHit {
  double distance = 0;              // ray parameter t (distance if the direction is unit length)
  Eigen::Vector3d point_in_screen;  // origin + t * direction
  Eigen::Vector2d uv;               // surface coordinates of the hit
  bool on_display = false;          // |u| <= 1 and |v| <= 1: inside the active area
};

// Where the ray origin + t * direction (t > 0) meets the screen surface. For a cylinder this is the far
// side: the exit point of the ray from the cylinder, which is the concave face the viewer sees whether the
// origin is inside or outside the cylinder. nullopt if the ray does not meet the surface in front of the
// origin. The hit may lie outside the active area (see on_display).
std::optional<SurfaceHit> IntersectSurface(const Monitor& m, const Eigen::Vector3d& origin_in_screen,
                                           const Eigen::Vector3d& direction_in_screen);

// The smallest (viewpoint - P) . n(P) over the active area: how far the viewpoint stands in front of the
// least-facing point of the display (mm). Positive means every point of the display faces the viewpoint
// (no part is seen edge-on or from behind).
double FrontClearanceMm(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen);

// The farthest viewpoint CheckViewpoint accepts from the screen centre: 1 km (a 1.2 m wide screen spans
// 0.07 deg there).
inline constexpr double kMaxViewpointDistanceMm = 1e6;

// Throws Error naming `where` if the viewpoint is not finite, farther than kMaxViewpointDistanceMm from the
// screen centre, or on or behind the screen surface (FrontClearanceMm <= 1e-3 mm: on the surface up to rounding,
// or behind it).
void CheckViewpoint(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen, const std::string& where);

}  // namespace curvecheck
