// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// The true surface of TrueMonitor's header comment as formulas (TrueGeometry), and a camera's rays against it
// (SurfaceIntersector): the geometry behind TrueSurfacePointInScreen (truth.json) and the tracer.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/math_util.h"
#include "core/monitor.h"
#include "synth/true_monitor.h"

namespace curvecheck {

struct SyntheticScene;

namespace synth_internal {

using curvecheck::kRadPerDeg;  // core/math_util.h

// The true surface of TrueMonitor's header comment, in the true centre frame, with the maps between it, its
// upright (unleaned) cylinder and the nominal screen frame. Holds a pointer to `truth` (for its bumps).
struct TrueGeometry {
  double k, half_w, half_h, cos_l, sin_l;
  Eigen::Matrix3d shear, upright_from_true, rotation;  // upright_from_true = shear^-1
  Eigen::Vector3d centre_in_screen;  // true screen centre in the nominal screen frame
  const TrueMonitor* truth;

  TrueGeometry(const Monitor& nominal, const TrueMonitor& truth);
  // phi = k s at u.
  double Phi(double u) const { return k * u * half_w; }
  // The leaned surface without deviation, C(u) + w a.
  Eigen::Vector3d BasePoint(const Eigen::Vector2d& uv) const {
    const double s = uv.x() * half_w, phi = k * s, h = Sinc(0.5 * phi), w = -uv.y() * half_h;
    return {s * Sinc(phi), w * cos_l, s * 0.5 * phi * h * h + w * sin_l};
  }
  // Unit normal of the leaned surface: dC/du x a = (-sin(phi) cos(l), -cos(phi) sin(l), cos(phi) cos(l)).
  Eigen::Vector3d Normal(const Eigen::Vector2d& uv) const {
    const double phi = Phi(uv.x());
    return Eigen::Vector3d(-std::sin(phi) * cos_l, -std::cos(phi) * sin_l, std::cos(phi) * cos_l).normalized();
  }
  // The deviated surface P(u, v) and, optionally, the base surface's normal there.
  Eigen::Vector3d Point(const Eigen::Vector2d& uv, Eigen::Vector3d* normal = nullptr) const {
    const Eigen::Vector3d n = Normal(uv);
    if (normal) *normal = n;
    return BasePoint(uv) + truth->DeviationMm(uv) * n;
  }
};

// The scene camera's rays against the true surface. Rays are traced in the upright true centre frame (the true
// centre frame mapped through the inverse lean shear), where the true screen is the upright cylinder
// k (x^2 + z^2) = 2 z: the camera origin is transformed once, directions by one fixed 3 x 3, and the quadratic's
// constant term is the same for every ray. Surface coordinates come from the hit point without atan2: on the
// cylinder sin(phi) = k x and cos(phi) = 1 - k z, so phi = 2 atan(k x / (2 - k z)) (half-angle form). Where a
// bump reaches, the hit is refined onto the deviated surface.
class SurfaceIntersector {
 public:
  // What the colour chain needs of a hit besides (u, v).
  struct HitGeometry {
    double t = 0;              // the ray parameter: the depth along the optical axis (mm) when d's camera z is 1
    double cos_incidence = 1;  // cosine of the angle between the ray and the base surface's normal there
  };

  // `max_abs_v`: rays that land beyond |v| > max_abs_v on the base surface, where no bump can move them, are
  // reported as misses without computing their u (the tracer passes the bezel's outer edge).
  SurfaceIntersector(const SyntheticScene& scene, double max_abs_v);

  // Camera-frame ray directions to the frame Intersect takes them in. Linear, so it commutes with interpolating
  // the rays.
  const Eigen::Matrix3d& upright_from_cam() const { return upright_from_cam_; }
  const TrueGeometry& geometry() const { return geometry_; }

  // Where the ray o + t d (o the camera, d in the upright frame) meets the true surface at t > 0, the side the
  // viewer sees: true with the surface coordinates (u, v) (any value; -1..1 is the display), false on a miss.
  // `refined` counts the rays refined onto the deviation field. `geometry` (optional) receives the hit's depth and
  // incidence (the normal of the base surface, leaned; a bump's slope is left out).
  bool Intersect(const Eigen::Vector3d& d, int64_t* refined, double* u, double* v,
                 HitGeometry* geometry = nullptr) const;

 private:
  // Moves (u, v) from the base surface onto the deviated one (see the definition).
  void Refine(const Eigen::Vector3d& d_upright, double sin_phi, double cos_phi, double* u, double* v) const;

  TrueGeometry geometry_;
  Eigen::Matrix3d upright_from_cam_;
  Eigen::Vector3d o_;                        // camera in the upright true centre frame
  double k_, c_term_;                        // curvature; c = k (o_x^2 + o_z^2) - 2 o_z
  double u_from_s_, u_from_phi_, v_from_y_;  // u = s / (W/2) = phi / (k W/2), v = -y / (H/2)
  double max_abs_v_;
  struct Box {
    double u0, u1, v0, v1;
  };
  std::vector<Box> bump_support_;  // where a bump's 4-sigma support (grown by the parallax of its height) lies
};

}  // namespace synth_internal
}  // namespace curvecheck
