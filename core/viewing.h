// What a viewer at a given point sees of a monitor: fields of view and angular pixel density.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/monitor.h"

namespace curvecheck {

struct ViewingGeometry {
  double distance_to_centre_mm = 0;  // |viewpoint - screen centre|
  double front_clearance_mm = 0;     // FrontClearanceMm: > 0 when every display point faces the viewer
  // Horizontal field of view: the angle swept, about the vertical axis through the viewpoint, by the
  // direction to the screen's horizontal centre line from the left to the right edge (can exceed 180 deg).
  double horizontal_fov_deg = 0;
  // Vertical field of view at the centre column: angle between the directions to its top and bottom ends.
  double vertical_fov_deg = 0;
  // Display pixels per degree of visual angle at the screen centre, across one pixel centred there.
  double pixels_per_degree_horizontal = 0;
  double pixels_per_degree_vertical = 0;
};

// Throws Error if the viewpoint is invalid (CheckViewpoint).
ViewingGeometry DescribeViewing(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen);

// Distance from the viewpoint to the nearest point of the display surface (the active area), mm. The surface's
// height depends only on v and its horizontal position only on u, so v is clamped analytically and u is found by
// a dense search refined by golden sections (exact to 1e-9 of the width for a smooth single minimum per bracket).
double NearestSurfaceDistanceMm(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen);

// The pixels per degree at which FLIP judges a rendering for this viewer (thesis 3.3): FLIP's flat-display
// formula, distance * (Nx / W) * pi/180, with the distance to the nearest point of the curved surface and W its
// arc length. It equals the angular density at that point when the nearest ray meets the surface at a right
// angle, which holds for viewpoints inside the cylinder sector (the thesis restricts them to it). Throws Error
// if the viewpoint is invalid.
double ViewerPixelsPerDegree(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen);

// The viewpoint in the screen frame from a viewpoint text "x,y,z" (mm) or a distance from the screen centre with an
// optional offset "X,Y" (ViewpointFromScreenCentre); nullopt when neither is given. Checked (CheckViewpoint),
// errors naming the option the user gave (--viewpoint, --distance-mm, --offset-mm).
std::optional<Eigen::Vector3d> ViewpointFromOptions(const Monitor& monitor, const std::string& viewpoint,
                                                    const std::optional<double>& distance_mm,
                                                    const std::optional<std::string>& offset_mm);

// "viewpoint (x, y, z) mm (screen frame), D mm from the screen centre": how commands print a viewpoint.
std::string DescribeViewpoint(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen);

// `curvecheck info`: the monitor's derived geometry and, from a viewpoint, its fields of view and pixel density;
// as text (one item a line) or as JSON (format curvecheck.info/1).
std::string MonitorInfoText(const Monitor& m, const std::optional<Eigen::Vector3d>& viewpoint_in_screen);
nlohmann::json MonitorInfoJson(const Monitor& m, const std::optional<Eigen::Vector3d>& viewpoint_in_screen);

}  // namespace curvecheck
