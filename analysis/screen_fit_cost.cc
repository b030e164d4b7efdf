#include "analysis/screen_fit_cost.h"

#include <ceres/jet.h>

#include <Eigen/Geometry>

namespace curvecheck {
namespace {

constexpr int kPoseSize = 7;
constexpr int kMaxCore = 3;
using CoreJet = ceres::Jet<double, kMaxCore>;  // the surface point's dependence on the core shape
using RotJet = ceres::Jet<double, 4>;          // the rotation's dependence on the quaternion (x, y, z, w)

}  // namespace

ReprojectionCost::ReprojectionCost(const CameraModel* camera, ScreenModelKind kind, double s_mm, double y_mm,
                                   double half_width_mm, const Eigen::Vector2d& detected_px,
                                   Eigen::VectorXd deviation_weights, bool free_intrinsics)
    : ReprojectionCost(PointProjector(*camera), kind, s_mm, y_mm, half_width_mm, detected_px,
                       std::move(deviation_weights), free_intrinsics) {}

ReprojectionCost::ReprojectionCost(const PointProjector& projector, ScreenModelKind kind, double s_mm, double y_mm,
                                   double half_width_mm, const Eigen::Vector2d& detected_px,
                                   Eigen::VectorXd deviation_weights, bool free_intrinsics)
    : projector_(projector),
      kind_(kind),
      s_mm_(s_mm),
      y_mm_(y_mm),
      half_width_mm_(half_width_mm),
      detected_px_(detected_px),
      w_(std::move(deviation_weights)),
      n_core_(CoreParameterCount(kind)),
      n_intrinsics_(free_intrinsics ? static_cast<int>(projector.model().intrinsics.size()) : 0) {
  set_num_residuals(2);
  mutable_parameter_block_sizes()->push_back(kPoseSize);
  if (n_core_ > 0) mutable_parameter_block_sizes()->push_back(n_core_);
  if (w_.size() > 0) mutable_parameter_block_sizes()->push_back(static_cast<int>(w_.size()));
  if (n_intrinsics_ > 0) mutable_parameter_block_sizes()->push_back(n_intrinsics_);
}

const double* ReprojectionCost::Intrinsics(double const* const* parameters) const {
  return n_intrinsics_ > 0 ? parameters[1 + (n_core_ > 0 ? 1 : 0) + (w_.size() > 0 ? 1 : 0)] : nullptr;
}

bool ReprojectionCost::PredictWithNormal(double const* const* parameters, Eigen::Vector2d* q_px,
                                         Eigen::Vector2d* dq_dnormal) const {
  const double* pose = parameters[0];
  double core[kMaxCore] = {0, 0, 0};
  for (int i = 0; i < n_core_; ++i) core[i] = parameters[1][i];
  Eigen::Vector3d n;
  Eigen::Vector3d p = CoreScreenPoint<double>(kind_, core, s_mm_, y_mm_, half_width_mm_, &n);
  if (w_.size() > 0) {
    p += w_.dot(Eigen::Map<const Eigen::VectorXd>(parameters[n_core_ > 0 ? 2 : 1], w_.size())) * n;
  }
  const Eigen::Quaterniond q = Eigen::Quaterniond(pose[3], pose[0], pose[1], pose[2]).normalized();
  const Eigen::Matrix3d cam_from_centre = q.toRotationMatrix().transpose();
  const Eigen::Vector3d x = cam_from_centre * (p - Eigen::Vector3d(pose[4], pose[5], pose[6]));
  if (!(x.z() > 0)) return false;
  Eigen::Matrix<double, 2, 3> dq_dx;
  *q_px = projector_.Project(x, &dq_dx, Intrinsics(parameters));
  if (dq_dnormal) *dq_dnormal = dq_dx * (cam_from_centre * n);
  return q_px->allFinite();
}

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* pose = parameters[0];
  const bool deviated = w_.size() > 0;
  const double* z = deviated ? parameters[n_core_ > 0 ? 2 : 1] : nullptr;
  const double d = deviated ? w_.dot(Eigen::Map<const Eigen::VectorXd>(z, w_.size())) : 0.0;
  const Eigen::Vector3d c(pose[4], pose[5], pose[6]);
  if (jacobians == nullptr) {
    // The cost only: plain doubles, the same formulas as below.
    double core[kMaxCore] = {0, 0, 0};
    for (int i = 0; i < n_core_; ++i) core[i] = parameters[1][i];
    Eigen::Vector3d n;
    Eigen::Vector3d p = CoreScreenPoint<double>(kind_, core, s_mm_, y_mm_, half_width_mm_, deviated ? &n : nullptr);
    if (deviated) p += n * d;
    // Normalized here, so that the function is defined off the unit sphere too (numeric differentiation steps
    // there); on it, the derivative along q is then zero, which the manifold's Plus never uses.
    Eigen::Quaterniond q(pose[3], pose[0], pose[1], pose[2]);
    q.coeffs() /= std::sqrt(q.coeffs().squaredNorm());
    const Eigen::Vector3d x = q.toRotationMatrix().transpose() * (p - c);
    if (!(x.z() > 0)) return false;
    const Eigen::Vector2d qpx = projector_.Project(x, nullptr, Intrinsics(parameters));
    if (!qpx.allFinite()) return false;
    residuals[0] = qpx.x() - detected_px_.x();
    residuals[1] = qpx.y() - detected_px_.y();
    return true;
  }
  CoreJet core[kMaxCore];
  for (int i = 0; i < n_core_; ++i) core[i] = CoreJet(parameters[1][i], i);
  Eigen::Matrix<CoreJet, 3, 1> n;
  Eigen::Matrix<CoreJet, 3, 1> p =
      CoreScreenPoint<CoreJet>(kind_, core, s_mm_, y_mm_, half_width_mm_, deviated ? &n : nullptr);
  if (deviated) p += n * CoreJet(d);
  RotJet qj[4];
  for (int i = 0; i < 4; ++i) qj[i] = RotJet(pose[i], i);
  Eigen::Quaternion<RotJet> q(qj[3], qj[0], qj[1], qj[2]);
  q.coeffs() /= sqrt(q.coeffs().squaredNorm());
  const Eigen::Matrix<RotJet, 3, 3> cam_from_centre = q.toRotationMatrix().transpose();
  const Eigen::Vector3d offset(p[0].a - c.x(), p[1].a - c.y(), p[2].a - c.z());
  const Eigen::Matrix<RotJet, 3, 1> x = cam_from_centre * offset.cast<RotJet>();
  const Eigen::Vector3d x0(x[0].a, x[1].a, x[2].a);
  if (!(x0.z() > 0)) return false;
  // With free intrinsics, libmrcal writes dq/dintrinsics (2 x n, row-major) straight into their Jacobian block.
  const int intr_block = 1 + (n_core_ > 0 ? 1 : 0) + (deviated ? 1 : 0);
  double* dq_di = n_intrinsics_ > 0 ? jacobians[intr_block] : nullptr;
  Eigen::Matrix<double, 2, 3> dq_dx;
  const Eigen::Vector2d qpx = projector_.Project(x0, &dq_dx, Intrinsics(parameters), dq_di);
  if (!qpx.allFinite()) return false;
  residuals[0] = qpx.x() - detected_px_.x();
  residuals[1] = qpx.y() - detected_px_.y();
  Eigen::Matrix3d r0;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r0(a, b) = cam_from_centre(a, b).a;
  }
  const Eigen::Matrix<double, 2, 3> dq_dp = dq_dx * r0;  // per mm of the surface point, centre frame
  if (jacobians[0]) {
    Eigen::Matrix<double, 3, 4> dx_dq;
    for (int r = 0; r < 3; ++r) dx_dq.row(r) = x[r].v.transpose();
    Eigen::Map<Eigen::Matrix<double, 2, kPoseSize, Eigen::RowMajor>> jac(jacobians[0]);
    jac.leftCols<4>() = dq_dx * dx_dq;
    jac.rightCols<3>() = -dq_dp;
  }
  int block = 1;
  if (n_core_ > 0) {
    if (jacobians[block]) {
      Eigen::Matrix<double, 3, kMaxCore> dp_dcore;
      for (int r = 0; r < 3; ++r) dp_dcore.row(r) = p[r].v.transpose();
      Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[block], 2, n_core_) =
          (dq_dp * dp_dcore).leftCols(n_core_);
    }
    ++block;
  }
  if (deviated && jacobians[block]) {
    const Eigen::Vector3d n0(n[0].a, n[1].a, n[2].a);
    const Eigen::Vector2d dq_dd = dq_dp * n0;
    Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[block], 2, w_.size()) =
        dq_dd * w_.transpose();
  }
  return true;
}

CoefficientPrior::CoefficientPrior(int n, double scale) : n_(n), scale_(scale) {
  set_num_residuals(n);
  mutable_parameter_block_sizes()->push_back(n);
}

bool CoefficientPrior::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  for (int i = 0; i < n_; ++i) residuals[i] = scale_ * parameters[0][i];
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(jacobians[0], n_, n_);
    jac.setZero();
    jac.diagonal().setConstant(scale_);
  }
  return true;
}

}  // namespace curvecheck
