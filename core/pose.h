// A rigid transform between two named frames, as a value (style.md rule 4; COLMAP's Rigid3d).
//
// Naming (architecture.md): a Pose variable is named target_from_source and maps points of the source frame into
// the target frame:  x_in_target = target_from_source * x_in_source = R x_in_source + t.
// So `cam_from_screen * point_in_screen` is the point in the camera frame, `a_from_b * b_from_c` is a_from_c, and
// the origin of the source frame seen in the target frame is `target_from_source.translation` (for
// screen_from_cam: the camera centre in the screen frame). Units: the translation in millimetres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

namespace curvecheck {

// The rotation of a rotation vector r (rad; Rodrigues, as mrcal's rt): by |r| about r / |r|; none for r = 0.
inline Eigen::AngleAxisd AngleAxisFromVector(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, r / angle) : Eigen::AngleAxisd(0, Eigen::Vector3d::UnitZ());
}

struct Pose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit quaternion
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();         // mm

  Pose() = default;
  Pose(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r.normalized()), translation(t) {}
  // From a rotation matrix whose columns are the source axes in the target frame.
  Pose(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) : rotation(Eigen::Quaterniond(r).normalized()), translation(t) {}

  static Pose Identity() { return {}; }
  // From mrcal's rt vector (rotation as a Rodrigues vector, rad; then the translation): the same convention,
  // mrcal's T_target_source (mrcal conventions, "Poses").
  static Pose FromRt(const std::array<double, 6>& rt) {
    return Pose(Eigen::Quaterniond(AngleAxisFromVector(Eigen::Vector3d(rt[0], rt[1], rt[2]))),
                Eigen::Vector3d(rt[3], rt[4], rt[5]));
  }
  std::array<double, 6> ToRt() const {
    const Eigen::AngleAxisd aa(rotation);
    const Eigen::Vector3d r = aa.angle() * aa.axis();
    return {r.x(), r.y(), r.z(), translation.x(), translation.y(), translation.z()};
  }

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  Pose Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Pose(inv, -(inv * translation));
  }
  Eigen::Vector3d operator*(const Eigen::Vector3d& x_in_source) const { return rotation * x_in_source + translation; }
  // (a_from_b * b_from_c) = a_from_c
  Pose operator*(const Pose& source_from_other) const {
    return Pose(rotation * source_from_other.rotation, rotation * source_from_other.translation + translation);
  }
  // A direction (no translation) from the source frame into the target frame.
  Eigen::Vector3d Rotate(const Eigen::Vector3d& direction_in_source) const { return rotation * direction_in_source; }
};

// Rotation angle between two poses' rotations, rad (0..pi).
inline double RotationDistanceRad(const Pose& a, const Pose& b) { return a.rotation.angularDistance(b.rotation); }

}  // namespace curvecheck
