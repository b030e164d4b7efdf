// The linear off-axis perspective projection used by the `warp` renderer's first pass (thesis Eq 4.4-4.6,
// after Kooima's generalized perspective projection), with the vertical near-plane extents widened for
// viewpoints above or below the screen (thesis 4.2.2) so that the frustum covers the whole curved surface.
//
// The near plane is the chord plane through the four corners of the display, z = -R cos(theta) in the screen
// frame (the screen itself for a flat monitor). Clip space follows thesis Eq 4.6: x, y in [-1, 1] (y up, as in
// the screen frame; a Vulkan renderer flips y itself), depth z_ndc in [0, 1] from near to far.
#pragma once

#include <Eigen/Core>

#include "core/monitor.h"

namespace curvecheck {

struct OffAxisFrustum {
  // Signed near-plane extents relative to the viewpoint, in mm at the near-plane distance (thesis Eq 4.5,
  // with bottom/top widened per 4.2.2).
  double left_mm = 0, right_mm = 0, bottom_mm = 0, top_mm = 0;
  double near_mm = 0;  // n: distance from the viewpoint to the chord plane along -z
  double far_mm = 0;   // f = n + depth
  bool vertical_extents_widened = false;  // true when 4.2.2 changed bottom or top
  Eigen::Vector3d viewpoint_in_screen = Eigen::Vector3d::Zero();
  // P T of thesis Eq 4.6: homogeneous clip coordinates from screen-frame points.
  Eigen::Matrix4d clip_from_screen = Eigen::Matrix4d::Identity();

  // Normalized device coordinates (x, y in [-1, 1] across the near plane, z in [0, 1]) of a point.
  Eigen::Vector3d NdcFromPoint(const Eigen::Vector3d& point_in_screen) const;
};

// Builds the frustum for a viewpoint. depth_mm is F of Eq 4.5 (far = near + F); it must reach past the
// pattern plane for a renderer to see it. Throws Error if the viewpoint is on or behind the chord plane
// (near <= 0): a linear projection cannot cover a field of view of 180 deg or more; or if it is not a valid
// viewpoint (CheckViewpoint).
OffAxisFrustum MakeOffAxisFrustum(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                                  double depth_mm = 10000);

}  // namespace curvecheck
