// The true, imperfect monitor of a synthetic scene: its own curvature, placement, lean and bumps, and the point
// of its surface at a display position. Part of the synthetic camera's public interface (synth/synthetic_camera.h
// includes it); the ray intersection that the tracer uses is internal (synth/true_surface.h).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace curvecheck {

struct SyntheticScene;

// The true screen, in its own centre frame (origin at the screen centre, axes as the screen frame's): the point
// of display position (u, v) is
//   P(u, v) = C(u) + (-v H / 2) a + DeviationMm(u, v) n(u, v),   a = (0, cos(lambda), sin(lambda)),
// (W and H the true width and height: the nominal ones times pitch_scale)
// where C(u) = (sin(k s)/k, 0, (1 - cos(k s))/k) is the arc of the true curvature k in the plane y = 0 at arc
// length s = u W/2 (C(u) = (s, 0, 0) when flat), lambda = lean_deg, and n is the unit normal of the leaned
// surface C(u) + w a (dC/du x a, toward the viewer). So every column is a straight segment of the true height
// H along the tilted axis a, every row a horizontal arc of the true radius: an affine shear Shear() of the
// upright cylinder, not a rigid rotation (which a camera pose could not tell from the camera moving). The
// nominal screen frame then sees centre_nominal + translation_mm + Rotation() P(u, v).
struct TrueMonitor {
  double curvature_per_mm = 0;                           // 1/R_true; 0 = flat
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // of the true screen centre in the nominal centre frame
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();    // rigid, about x, y, z through the centre (applied z y x)
  double lean_deg = 0;  // axis tilt lambda (above); positive moves the top edge toward the viewer; |lambda| < 45
  // The true pixel pitch over the datasheet's: W and H above are the nominal ones times this (a panel within its
  // pitch tolerance; the analysis assumes the datasheet's pitch, so it sees the scene scaled by its inverse).
  double pitch_scale = 1;
  struct Bump {
    double u = 0, v = 0;              // centre in surface coordinates (-1..1)
    double sigma_u = 0.1, sigma_v = 0.1;
    double height_mm = 0;             // peak deviation along the normal, toward the viewer
  };
  std::vector<Bump> bumps;

  // Rigid rotation taking true-centre-frame vectors to the nominal centre frame (rotation_deg only).
  Eigen::Matrix3d Rotation() const;
  // The lean as a linear map of the upright cylinder's centre frame onto the true centre frame:
  // (x, y, z) -> (x, y cos(lambda), z + y sin(lambda)).
  Eigen::Matrix3d Shear() const;
  // Deviation along the normal at (u, v), mm. The photo's ray tracer ignores each bump beyond 4 sigma (where it
  // is below exp(-8) = 3.4e-4 of its height); truth.json uses this full sum.
  double DeviationMm(const Eigen::Vector2d& uv) const;
};

// The definition of the lean, as written into truth.json.
inline constexpr const char* kLeanDefinition =
    "axis tilt: P(u,v) = C(u) + (-v H/2) (0, cos(lean), sin(lean)) in the true centre frame, C(u) the arc of the "
    "true radius in the plane y = 0; positive lean moves the top edge toward the viewer; rows stay arcs of the "
    "true radius, columns straight segments of length H; rotation_deg (rigid) and translation_mm apply after it";

// Point of the true surface at (u, v), in the nominal screen frame, and its unit normal (toward the viewer).
Eigen::Vector3d TrueSurfacePointInScreen(const SyntheticScene& scene, const Eigen::Vector2d& uv,
                                         Eigen::Vector3d* normal_in_screen = nullptr);

}  // namespace curvecheck
