#include "synth/true_monitor.h"

#include <Eigen/Geometry>
#include <cmath>

#include "synth/scene.h"
#include "synth/true_surface.h"

namespace curvecheck {

using synth_internal::kRadPerDeg;

Eigen::Matrix3d TrueMonitor::Rotation() const {
  const Eigen::Vector3d r = rotation_deg * kRadPerDeg;
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Matrix3d TrueMonitor::Shear() const {
  // (x, w, z) upright -> (x, w cos(lambda), z + w sin(lambda)): the column through each point turns into the
  // axis a = (0, cos(lambda), sin(lambda)) while x and z stay, so rows keep their arcs.
  const double l = lean_deg * kRadPerDeg;
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, std::cos(l), 0, 0, std::sin(l), 1;
  return m;
}

double TrueMonitor::DeviationMm(const Eigen::Vector2d& uv) const {
  double d = 0;
  for (const Bump& b : bumps) {
    const double du = (uv.x() - b.u) / b.sigma_u, dv = (uv.y() - b.v) / b.sigma_v;
    d += b.height_mm * std::exp(-0.5 * (du * du + dv * dv));
  }
  return d;
}

Eigen::Vector3d TrueSurfacePointInScreen(const SyntheticScene& s, const Eigen::Vector2d& uv, Eigen::Vector3d* normal) {
  const synth_internal::TrueGeometry g(s.monitor, s.truth);
  Eigen::Vector3d n;
  const Eigen::Vector3d p = g.Point(uv, &n);  // the normal ignores the slope of the deviation field (smooth, small)
  if (normal) *normal = g.rotation * n;
  return g.centre_in_screen + g.rotation * p;
}

}  // namespace curvecheck
