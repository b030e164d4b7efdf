#include "core/look_at.h"

#include <Eigen/Geometry>

#include "core/error.h"

namespace curvecheck {

Pose ScreenFromCamLookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& look_at,
                         const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (look_at - position).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  if (!x.allFinite() || x.norm() < 0.5) {
    throw Error("camera", "the up vector is parallel to the viewing direction", "give another up vector");
  }
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return Pose(r, position);
}

}  // namespace curvecheck
