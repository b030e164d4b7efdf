// A camera pose from its position and the point it looks at (the synthetic camera's scenes and the capture
// plan).
#pragma once

#include <Eigen/Core>

#include "core/pose.h"

namespace curvecheck {

// The camera at `position` (screen frame, mm) looking at look_at: camera z toward look_at, x = z cross up,
// y = z cross x (down). Throws Error if up is parallel to the viewing direction.
Pose ScreenFromCamLookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& look_at,
                         const Eigen::Vector3d& up);

}  // namespace curvecheck
