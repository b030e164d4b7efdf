// The reprojection residual of the screen fit (one feature in one photo), with its analytic Jacobian.
//
//   r = q(X) - q_detected   (px),   X = centre_from_cam^T (P(s, y; shape) + d(u, v) n(s) - c)
//
// q: the mrcal lens model through libmrcal (core/camera_model.h PointProjector), whose gradient dq/dX is exact;
// P, n: CoreScreenPoint (analysis/screen_model.h); d = w . z the deviation field (cylinder+deviation only);
// centre_from_cam: unit quaternion (Eigen order x, y, z, w), c: the camera position in the centre frame (mm).
// The chain rule dr/dparams = dq/dX dX/dparams uses Ceres Jets for the rotation's dependence on the quaternion
// (4 values) and for the surface point's on the core shape (up to 3), and closed forms for the rest:
// dX/dc = -centre_from_cam^T, dX/dshape = centre_from_cam^T dP/dshape and dX/dz = centre_from_cam^T n w^T for the
// (linear) deviation coefficients. Without Jacobians (Ceres's cost-only evaluations) it runs in plain doubles.
//
// Parameter blocks, in order: pose (7: quaternion, then c), core shape (CoreParameterCount values; absent when
// 0), deviation coefficients (w.size(); absent when empty), the lens intrinsics (camera->intrinsics.size(), in
// mrcal's order; only with free_intrinsics, for the self-calibration from the screen: calibrate/from_screen.h;
// then q uses these intrinsics and dr/d(intrinsics) is libmrcal's dq/dintrinsics). Evaluate returns false when
// the point is behind the camera (X_z <= 0), so Ceres rejects that step.
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>

#include "analysis/screen_model.h"
#include "core/camera_model.h"

namespace curvecheck {

class ReprojectionCost final : public ceres::CostFunction {
 public:
  // `camera` must outlive the cost function.
  ReprojectionCost(const CameraModel* camera, ScreenModelKind kind, double s_mm, double y_mm, double half_width_mm,
                   const Eigen::Vector2d& detected_px, Eigen::VectorXd deviation_weights = {},
                   bool free_intrinsics = false);
  // The same with the camera's projector shared among many costs (its lens model parsed once; with free
  // intrinsics, projector.model() seeds only their count: the values come from the intrinsics block).
  ReprojectionCost(const PointProjector& projector, ScreenModelKind kind, double s_mm, double y_mm,
                   double half_width_mm, const Eigen::Vector2d& detected_px, Eigen::VectorXd deviation_weights = {},
                   bool free_intrinsics = false);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  // The predicted pixel and the image motion per mm of displacement along the model surface's normal
  // (px/mm), at the given parameters (same blocks as Evaluate). False when behind the camera.
  bool PredictWithNormal(double const* const* parameters, Eigen::Vector2d* q_px, Eigen::Vector2d* dq_dnormal) const;

 private:
  PointProjector projector_;
  ScreenModelKind kind_;
  double s_mm_, y_mm_, half_width_mm_;
  Eigen::Vector2d detected_px_;
  Eigen::VectorXd w_;
  int n_core_;
  int n_intrinsics_ = 0;  // > 0: the intrinsics are the last parameter block

  // The intrinsics to project with: the intrinsics block's values, or nullptr (the projector's model's) when fixed.
  const double* Intrinsics(double const* const* parameters) const;
};

// Zero-mean Gaussian prior on a block of n coefficients: r = z * (noise_px / prior_sigma), so that the residual
// is in the same units as a pixel residual of noise noise_px.
class CoefficientPrior final : public ceres::CostFunction {
 public:
  CoefficientPrior(int n, double scale);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  int n_;
  double scale_;
};

}  // namespace curvecheck
