// Per-pixel camera rays from a lens model, precomputed on a grid, and a process-wide cache of them. Part of the
// synthetic camera's public interface (synth/synthetic_camera.h includes it).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/camera_model.h"
#include "synth/lens_misfit.h"

namespace curvecheck {

// Per-pixel camera rays from the lens model: unprojected through mrcal on a grid of `spacing_px`, interpolated
// bicubically in normalized coordinates (x/z, y/z) onto a dense table of `dense_px` spacing, which is then read
// bilinearly (4 taps per ray instead of 16; the error of both steps is measured by MeasureErrorPx).
class RayGrid {
 public:
  // Throws Error if the lens sees rays at more than 87 deg from its axis. `misfit` (optional, kept only during
  // construction): the true lens's departure from the model; the ray through pixel p is then the model's ray
  // through misfit->ModelPixelOf(p).
  RayGrid(const CameraModel& camera, double spacing_px, double dense_px = 4, const LensMisfit* misfit = nullptr);
  // Ray direction (camera frame, z = 1, not unit length) through pixel coordinates q.
  Eigen::Vector3d Ray(const Eigen::Vector2d& q) const;
  // Row-coherent form of Ray(): the dense nodes' (x/z, y/z) interpolated to row y_px, one per dense column.
  // Ray(q) with q.y() = y_px is the linear interpolation of nodes[i], nodes[i + 1] at DenseColumn(q.x()).
  void RowNodes(double y_px, std::vector<Eigen::Vector2d>* nodes) const;
  // Dense column i (clamped so that i + 1 exists) and fraction f for pixel x coordinate x_px.
  void DenseColumn(double x_px, int* i, double* f) const;
  // Worst reprojection error (px) of interpolated rays over `samples` random pixels, against mrcal's projection
  // (followed by the misfit's, if given).
  double MeasureErrorPx(const CameraModel& camera, int samples, uint64_t seed,
                        const LensMisfit* misfit = nullptr) const;

 private:
  double spacing_;
  int nx_, ny_;
  std::vector<Eigen::Vector2f> normalized_;  // (x/z, y/z) at the coarse nodes, row-major
  Eigen::Vector2d Node(int i, int j) const;
  Eigen::Vector2d Bicubic(const Eigen::Vector2d& q) const;
  double dense_spacing_;
  int dense_nx_ = 0, dense_ny_ = 0;
  std::vector<Eigen::Vector2d> dense_;  // (x/z, y/z) at (i * dense - 0.5, j * dense - 0.5)
};

// The ray table for `camera` with grid spacing `spacing_px`, built on first use and kept for the process (the
// last 4 lenses), so that a sweep of photos through one lens pays for mrcal's unprojection once. Thread-safe.
// `from_cache` (optional) is set to whether the table was built by an earlier call.
std::shared_ptr<const RayGrid> SharedRayGrid(const CameraModel& camera, double spacing_px,
                                             bool* from_cache = nullptr, const LensMisfit* misfit = nullptr);

}  // namespace curvecheck
