// The correction mapping of a rendering (architecture.md, "Virtual pattern"): the display shows, at each
// display pixel, the point of the pattern plane where the ray from the viewpoint through that pixel's point
// on the nominal surface meets the plane. Seen from the viewpoint, an ideal monitor then shows an exact planar
// perspective image of the pattern.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "core/monitor.h"

namespace curvecheck {

// A plane in the screen frame with 2D pattern coordinates (a, b) in mm:
// point = origin + a * x_axis + b * y_axis.
struct PatternPlane {
  Eigen::Vector3d origin_in_screen = Eigen::Vector3d::Zero();
  Eigen::Vector3d x_axis_in_screen = Eigen::Vector3d::UnitX();  // unit
  Eigen::Vector3d y_axis_in_screen = Eigen::Vector3d::UnitY();  // unit, orthogonal to x_axis

  // x_axis cross y_axis: +z for the default plane, toward the viewer.
  Eigen::Vector3d Normal() const { return x_axis_in_screen.cross(y_axis_in_screen); }
  Eigen::Vector3d PointInScreen(const Eigen::Vector2d& pattern_mm) const {
    return origin_in_screen + pattern_mm.x() * x_axis_in_screen + pattern_mm.y() * y_axis_in_screen;
  }
  // Throws Error naming `where` unless the values are finite and the axes orthonormal (to 1e-9).
  void Check(const std::string& where) const;
};

// The default pattern plane: tangent to the screen at its centre, pattern x right and y up (the plane z = -R;
// z = 0 for a flat monitor).
PatternPlane TangentPlaneAtCentre(const Monitor& m);

// Display pixel -> pattern coordinates (mm) of the point that pixel must show. nullopt if the ray from the
// viewpoint through the pixel's surface point does not meet the plane in front of the viewpoint.
std::optional<Eigen::Vector2d> PatternFromDisplayPx(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                                                    const PatternPlane& plane, const Eigen::Vector2d& display_px);

// Any 3D point -> the display pixel where the ray from the viewpoint toward it meets the screen surface
// (far side; see IntersectSurface). The pixel may lie outside the display (coordinates beyond
// [-0.5, N - 0.5]); nullopt if the ray misses the cylinder.
std::optional<Eigen::Vector2d> DisplayPxFromPoint(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                                                  const Eigen::Vector3d& point_in_screen);

// Pattern coordinates -> display pixel: the inverse of PatternFromDisplayPx.
std::optional<Eigen::Vector2d> DisplayPxFromPattern(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                                                    const PatternPlane& plane, const Eigen::Vector2d& pattern_mm);

}  // namespace curvecheck
