// Test and benchmark helpers for the screen fit: observations drawn from a synthetic scene's true geometry
// (synth/synthetic_camera.h) with seeded Gaussian noise. Tests and benchmarks only.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "analysis/screen_fit.h"
#include "synth/synthetic_camera.h"
#include "core/camera_model.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"

namespace curvecheck::testing {

// nx x ny display positions on a regular grid, inset by `margin` of the size on every side (like the inner
// corners of a checkerboard spanning the screen).
inline std::vector<Eigen::Vector2d> DisplayGrid(const Monitor& m, int nx, int ny, double margin = 0.04) {
  std::vector<Eigen::Vector2d> px;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double fu = margin + (1 - 2 * margin) * i / (nx - 1), fv = margin + (1 - 2 * margin) * j / (ny - 1);
      px.emplace_back(fu * m.width_px - 0.5, fv * m.height_px - 0.5);
    }
  }
  return px;
}

// Where a true surface point is, in the nominal screen frame, for a display coordinate (u, v).
using SurfaceFn = std::function<Eigen::Vector3d(const Eigen::Vector2d& uv)>;

// The scene's own truth (TrueSurfacePointInScreen).
inline SurfaceFn SceneSurface(const SyntheticScene& scene) {
  return [&scene](const Eigen::Vector2d& uv) { return TrueSurfacePointInScreen(scene, uv); };
}

// The axis-tilt lean of the fit's cylinder+lean model (analysis/screen_model.h), written out independently:
// P = centre + (sin(k s)/k, y cos(lambda), (1 - cos(k s))/k + y sin(lambda)), k = the scene's true curvature.
inline SurfaceFn AxisLeanSurface(const SyntheticScene& scene, double lean_deg) {
  return [&scene, lean_deg](const Eigen::Vector2d& uv) {
    const double k = scene.truth.curvature_per_mm, lambda = lean_deg / kDegPerRad;
    const double s = 0.5 * uv.x() * scene.monitor.width_mm, y = -0.5 * uv.y() * scene.monitor.height_mm;
    Eigen::Vector3d p = ScreenCentreInScreen(scene.monitor);
    p.x() += std::sin(k * s) / k;
    p.y() += y * std::cos(lambda);
    p.z() += (1 - std::cos(k * s)) / k + y * std::sin(lambda);
    return p;
  };
}

// The camera pose of the scene in the nominal centre frame.
inline Pose ScenePose(const SyntheticScene& scene) {
  return Pose(scene.screen_from_cam.rotation, scene.screen_from_cam.translation - ScreenCentreInScreen(scene.monitor));
}

// Observations of the features at `display_px` (those that project into the image), each detected with
// isotropic Gaussian noise of noise_px per coordinate.
inline PhotoObservations Observe(const SyntheticScene& scene, const std::vector<Eigen::Vector2d>& display_px,
                                 double noise_px, std::mt19937_64& rng, const SurfaceFn& surface,
                                 const std::string& name = "photo") {
  std::normal_distribution<double> noise(0, noise_px);
  PhotoObservations obs;
  obs.photo = name;
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector2d& px : display_px) {
    const Eigen::Vector3d p = surface(UvFromDisplayPx(scene.monitor, px));
    points.push_back(scene.screen_from_cam.Inverse() * p);
  }
  const std::vector<Eigen::Vector2d> q = ProjectPoints(scene.camera, points);
  for (size_t i = 0; i < display_px.size(); ++i) {
    const double nx = noise(rng), ny = noise(rng);  // drawn for every feature, so seeds stay aligned
    if (!(points[i].z() > 0) || q[i].x() < 0 || q[i].y() < 0 || q[i].x() > scene.camera.width - 1 ||
        q[i].y() > scene.camera.height - 1) {
      continue;
    }
    obs.ids.push_back("c" + std::to_string(i));
    obs.display_px.push_back(display_px[i]);
    obs.detected_px.push_back(q[i] + Eigen::Vector2d(nx, ny));
  }
  return obs;
}

}  // namespace curvecheck::testing
