#include "analysis/screen_fit_cost.h"

#include <ceres/jet.h>

#include <Eigen/Geometry>

namespace curvecheck {
namespace {

constexpr int kPoseSize = 7;
constexpr int kMaxCore = 3;
using Jet = ceres::Jet<double, kPoseSize + kMaxCore>;

}  // namespace

ReprojectionCost::ReprojectionCost(const CameraModel* camera, ScreenModelKind kind, double s_mm, double y_mm,
                                   double half_width_mm, const Eigen::Vector2d& detected_px,
                                   Eigen::VectorXd deviation_weights, bool free_intrinsics)
    : camera_(camera),
      kind_(kind),
      s_mm_(s_mm),
      y_mm_(y_mm),
      half_width_mm_(half_width_mm),
      detected_px_(detected_px),
      w_(std::move(deviation_weights)),
      n_core_(CoreParameterCount(kind)),
      n_intrinsics_(free_intrinsics ? static_cast<int>(camera->intrinsics.size()) : 0) {
  set_num_residuals(2);
  mutable_parameter_block_sizes()->push_back(kPoseSize);
  if (n_core_ > 0) mutable_parameter_block_sizes()->push_back(n_core_);
  if (w_.size() > 0) mutable_parameter_block_sizes()->push_back(static_cast<int>(w_.size()));
  if (n_intrinsics_ > 0) mutable_parameter_block_sizes()->push_back(n_intrinsics_);
}

CameraModel ReprojectionCost::Camera(double const* const* parameters) const {
  CameraModel cam = *camera_;
  if (n_intrinsics_ > 0) {
    const double* intr = parameters[1 + (n_core_ > 0 ? 1 : 0) + (w_.size() > 0 ? 1 : 0)];
    cam.intrinsics.assign(intr, intr + n_intrinsics_);
  }
  return cam;
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
  std::vector<Eigen::Matrix<double, 2, 3>> dq_dx;
  *q_px = ProjectPoints(Camera(parameters), {x}, &dq_dx).front();
  if (dq_dnormal) *dq_dnormal = dq_dx.front() * (cam_from_centre * n);
  return q_px->allFinite();
}

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const bool want_jacobians = jacobians != nullptr;
  const double* pose = parameters[0];
  Jet pj[kPoseSize];
  for (int i = 0; i < kPoseSize; ++i) pj[i] = Jet(pose[i], i);
  Jet core[kMaxCore];
  for (int i = 0; i < n_core_; ++i) core[i] = Jet(parameters[1][i], kPoseSize + i);
  const bool deviated = w_.size() > 0;
  Eigen::Matrix<Jet, 3, 1> n;
  Eigen::Matrix<Jet, 3, 1> p = CoreScreenPoint<Jet>(kind_, core, s_mm_, y_mm_, half_width_mm_, deviated ? &n : nullptr);
  const double* z = deviated ? parameters[n_core_ > 0 ? 2 : 1] : nullptr;
  if (deviated) {
    const double d = w_.dot(Eigen::Map<const Eigen::VectorXd>(z, w_.size()));
    p += n * Jet(d);
  }
  // Normalized here, so that the function is defined off the unit sphere too (numeric differentiation steps
  // there); on it, the derivative along q is then zero, which the manifold's Plus never uses.
  Eigen::Quaternion<Jet> q(pj[3], pj[0], pj[1], pj[2]);
  q.coeffs() /= sqrt(q.coeffs().squaredNorm());
  const Eigen::Matrix<Jet, 3, 3> cam_from_centre = q.toRotationMatrix().transpose();
  const Eigen::Matrix<Jet, 3, 1> x = cam_from_centre * (p - Eigen::Matrix<Jet, 3, 1>(pj[4], pj[5], pj[6]));
  const Eigen::Vector3d x0(x[0].a, x[1].a, x[2].a);
  if (!(x0.z() > 0)) return false;
  std::vector<Eigen::Matrix<double, 2, 3>> dq_dx;
  std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> dq_di;
  const int intr_block = 1 + (n_core_ > 0 ? 1 : 0) + (deviated ? 1 : 0);
  const bool want_di = want_jacobians && n_intrinsics_ > 0 && jacobians[intr_block] != nullptr;
  const Eigen::Vector2d qpx =
      ProjectPoints(Camera(parameters), {x0}, want_jacobians ? &dq_dx : nullptr, want_di ? &dq_di : nullptr).front();
  if (!qpx.allFinite()) return false;
  residuals[0] = qpx.x() - detected_px_.x();
  residuals[1] = qpx.y() - detected_px_.y();
  if (!want_jacobians) return true;
  Eigen::Matrix<double, 3, kPoseSize + kMaxCore> dx_dp;
  for (int r = 0; r < 3; ++r) dx_dp.row(r) = x[r].v.transpose();
  const Eigen::Matrix<double, 2, kPoseSize + kMaxCore> j = dq_dx.front() * dx_dp;
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 2, kPoseSize, Eigen::RowMajor>> jac(jacobians[0]);
    jac = j.leftCols<kPoseSize>();
  }
  int block = 1;
  if (n_core_ > 0) {
    if (jacobians[block]) {
      Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[block], 2, n_core_) =
          j.middleCols(kPoseSize, n_core_);
    }
    ++block;
  }
  if (deviated && jacobians[block]) {
    Eigen::Matrix3d r0;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) r0(a, b) = cam_from_centre(a, b).a;
    }
    const Eigen::Vector3d n0(n[0].a, n[1].a, n[2].a);
    const Eigen::Vector2d dq_dd = dq_dx.front() * (r0 * n0);
    Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[block], 2, w_.size()) =
        dq_dd * w_.transpose();
  }
  if (want_di) {
    Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[intr_block], 2, n_intrinsics_) =
        dq_di.front();
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
