// The Ceres problem of one candidate screen model (analysis/screen_fit_internal.h): its cost functions and
// parameter blocks, the solve, the residuals, the initial poses from PnP and the covariances at the solution.
#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "analysis/screen_fit_internal.h"
#include "core/error.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"
#include "core/stats.h"

namespace curvecheck::screen_fit_internal {
namespace {

// The free intrinsics' outcome (FitOptions::fit_intrinsics): their values, their covariance (marginal over the poses
// and the shape: a block of the joint covariance), their covariance with the curvature k (grad: dk/dcore) and, per
// photo, the correlation of the focal length fx with the camera's distance from the screen centre |c|.
void JointIntrinsics(const Setup& setup, const State& st, const Linearization& lin, double var,
                     const Eigen::VectorXd& grad, ModelFit* fit) {
  const int ni = static_cast<int>(st.intr.size()), nc = static_cast<int>(st.core.size());
  const Eigen::MatrixXd& c = lin.normal_pinv;
  fit->intrinsics = st.intr;
  const Eigen::MatrixXd ci = c.block(lin.intr_offset, lin.intr_offset, ni, ni);
  fit->intrinsics_covariance = var * ci;
  if (nc > 0) {
    const Eigen::MatrixXd cki = c.block(lin.core_offset, lin.intr_offset, nc, ni);
    fit->intrinsics_curvature_cov = var * (grad.transpose() * cki).transpose();
  }
  fit->focal_distance_correlation.assign(static_cast<size_t>(setup.photos), kNaN);
  for (int p = 0; p < setup.photos; ++p) {
    const int o = lin.pose_offset[static_cast<size_t>(p)];
    if (o < 0) continue;
    const PoseBlock& pose = st.poses[static_cast<size_t>(p)];
    const Eigen::Vector3d centre(pose[4], pose[5], pose[6]);
    const Eigen::Vector3d u = centre.normalized();  // d|c|/dc
    const double var_d = u.dot(c.block<3, 3>(o + 3, o + 3) * u);
    const double cov_df = u.dot(c.block(o + 3, lin.intr_offset, 3, 1).col(0));
    if (var_d > 0 && ci(0, 0) > 0) {
      fit->focal_distance_correlation[static_cast<size_t>(p)] = cov_df / std::sqrt(var_d * ci(0, 0));
    }
  }
}

}  // namespace

std::unique_ptr<ReprojectionCost> MakeCost(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                                           const Obs& o) {
  Eigen::VectorXd w;
  if (kind == ScreenModelKind::kCylinderDeviation) w = basis->Weights(o.uv);
  const bool shared = setup.projector && &setup.projector->model() == setup.camera;
  return std::make_unique<ReprojectionCost>(shared ? *setup.projector : PointProjector(*setup.camera), kind, o.s_mm,
                                            o.y_mm, setup.half_width_mm, o.detected, std::move(w),
                                            setup.options->fit_intrinsics);
}

std::vector<const double*> Blocks(const State& st, int photo) {
  std::vector<const double*> b = {st.poses[static_cast<size_t>(photo)].data()};
  if (!st.core.empty()) b.push_back(st.core.data());
  if (!st.dev.empty()) b.push_back(st.dev.data());
  if (!st.intr.empty()) b.push_back(st.intr.data());
  return b;
}

BuiltProblem Build(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                   const std::vector<bool>& active, bool robust, State* st) {
  BuiltProblem b;
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.enable_fast_removal = false;
  b.problem = std::make_unique<ceres::Problem>(po);
  if (robust) {
    b.loss = std::make_unique<ceres::HuberLoss>(setup.options->huber_sigmas * setup.options->expected_noise_px);
  }
  b.pose_manifold = std::make_unique<ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>>(
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<3>());
  std::vector<bool> pose_used(static_cast<size_t>(setup.photos), false);
  for (size_t i = 0; i < setup.obs.size(); ++i) {
    if (!active[i]) continue;
    const Obs& o = setup.obs[i];
    std::vector<double*> blocks = {st->poses[static_cast<size_t>(o.photo)].data()};
    if (!st->core.empty()) blocks.push_back(st->core.data());
    if (!st->dev.empty()) blocks.push_back(st->dev.data());
    if (!st->intr.empty()) blocks.push_back(st->intr.data());
    b.blocks.push_back(b.problem->AddResidualBlock(MakeCost(setup, kind, basis, o).release(), b.loss.get(), blocks));
    b.obs_index.push_back(i);
    pose_used[static_cast<size_t>(o.photo)] = true;
  }
  for (int p = 0; p < setup.photos; ++p) {
    if (pose_used[static_cast<size_t>(p)]) {
      b.problem->SetManifold(st->poses[static_cast<size_t>(p)].data(), b.pose_manifold.get());
    }
  }
  if (!st->dev.empty()) {
    const double scale = setup.options->expected_noise_px / setup.options->deviation_prior_mm;
    b.blocks.push_back(b.problem->AddResidualBlock(new CoefficientPrior(static_cast<int>(st->dev.size()), scale),
                                                   nullptr, st->dev.data()));
  }
  return b;
}

ceres::Solver::Summary Solve(const Setup& setup, BuiltProblem& b, State* st) {
  ceres::Solver::Options so;
  so.max_num_iterations = setup.options->max_iterations;
  so.function_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  if (!st->intr.empty()) {
    // Free intrinsics (the calibration from the screen): their scales differ by 10^5 (fx against k2) and the reduced
    // camera matrix of a Schur step was not positive definite far from the solution; QR on the small dense
    // Jacobian (a few thousand rows, ~60 columns) has no normal equations to lose.
    so.linear_solver_type = ceres::DENSE_QR;
  } else if (!st->core.empty() || !st->dev.empty()) {
    // Poses touch disjoint residuals: eliminate them (Schur), leaving a small dense system in the shape.
    so.linear_solver_type = ceres::DENSE_SCHUR;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (PoseBlock& pose : st->poses) {
      if (b.problem->HasParameterBlock(pose.data())) ordering->AddElementToGroup(pose.data(), 0);
    }
    if (!st->core.empty()) ordering->AddElementToGroup(st->core.data(), 1);
    if (!st->dev.empty()) ordering->AddElementToGroup(st->dev.data(), 1);
    if (!st->intr.empty()) ordering->AddElementToGroup(st->intr.data(), 1);
    so.linear_solver_ordering = ordering;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;  // poses only: block diagonal
  } else {
    so.linear_solver_type = ceres::DENSE_QR;
  }
  ceres::Solver::Summary summary;
  ceres::Solve(so, b.problem.get(), &summary);
  return summary;
}

// Residuals detected - predicted of all observations (NaN where the point is behind the camera).
std::vector<Eigen::Vector2d> Residuals(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                                       const State& st) {
  std::vector<Eigen::Vector2d> r(setup.obs.size());
  for (size_t i = 0; i < setup.obs.size(); ++i) {
    const Obs& o = setup.obs[i];
    double res[2];
    const std::vector<const double*> blocks = Blocks(st, o.photo);
    r[i] = MakeCost(setup, kind, basis, o)->Evaluate(blocks.data(), res, nullptr) ? Eigen::Vector2d(-res[0], -res[1])
                                                                                  : Eigen::Vector2d(kNaN, kNaN);
  }
  return r;
}

// Robust per-coordinate noise: 1.4826 x the median absolute coordinate residual.
double MadSigma(const std::vector<Eigen::Vector2d>& r) {
  std::vector<double> a;
  a.reserve(2 * r.size());
  for (const Eigen::Vector2d& x : r) {
    if (!x.allFinite()) continue;
    a.push_back(std::abs(x.x()));
    a.push_back(std::abs(x.y()));
  }
  return a.empty() ? kNaN : 1.4826 * Median(std::move(a));  // core/stats.h
}

// PnP against the nominal geometry on undistorted normalized coordinates (RANSAC, then iterative refinement).
PoseBlock InitialPose(const Setup& setup, int photo) {
  const Monitor& m = *setup.nominal;
  std::vector<cv::Point3d> object;
  std::vector<Eigen::Vector2d> pixels;
  for (const Obs& o : setup.obs) {
    if (o.photo != photo) continue;
    const Eigen::Vector3d p = SurfacePointFromUv(m, o.uv) - ScreenCentreInScreen(m);
    object.emplace_back(p.x(), p.y(), p.z());
    pixels.push_back(o.detected);
  }
  const std::vector<Eigen::Vector3d> rays = UnprojectPixels(*setup.camera, pixels);
  std::vector<cv::Point2d> image;
  for (const Eigen::Vector3d& v : rays) image.emplace_back(v.x() / v.z(), v.y() / v.z());
  const cv::Matx33d k = cv::Matx33d::eye();
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const double focal = setup.camera->intrinsics.empty() ? 1000 : setup.camera->intrinsics[0];
  bool ok = cv::solvePnPRansac(object, image, k, cv::noArray(), rvec, tvec, false, 200, 10.0 / focal, 0.99, inliers,
                               cv::SOLVEPNP_EPNP);
  if (ok && inliers.size() >= 6) {
    std::vector<cv::Point3d> oi;
    std::vector<cv::Point2d> ii;
    for (int i : inliers) {
      oi.push_back(object[static_cast<size_t>(i)]);
      ii.push_back(image[static_cast<size_t>(i)]);
    }
    ok = cv::solvePnP(oi, ii, k, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
  }
  if (!ok) ok = cv::solvePnP(object, image, k, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_SQPNP);
  if (!ok) {
    throw Error("photo " + std::to_string(photo), "the camera pose could not be initialized (PnP failed)",
                "check that the detections belong to this pattern and camera model");
  }
  cv::Mat rmat;
  cv::Rodrigues(rvec, rmat);
  Eigen::Matrix3d cam_from_centre;
  cv::cv2eigen(rmat, cam_from_centre);
  Eigen::Vector3d t;
  cv::cv2eigen(tvec, t);
  const Eigen::Quaterniond q(cam_from_centre.transpose());
  const Eigen::Vector3d c = -cam_from_centre.transpose() * t;
  return {q.x(), q.y(), q.z(), q.w(), c.x(), c.y(), c.z()};
}

// The parameters' covariance, scaled by the residual noise, from the final fit's linearization (Linearize: the
// equilibrated pseudo-inverse of J^T J in the tangent space; the same as Ceres's covariance of the problem where J
// has full rank, without a sparse QR of the whole Jacobian per candidate). Directions of the equilibrated J^T J
// below 1e-12 of its largest eigenvalue are dropped and the fit is marked ill-conditioned.
void Covariances(const Setup& setup, ModelWork& w, ModelFit* fit) {
  State& st = w.state;
  if (!w.lin) {
    fit->ill_conditioned = true;
    fit->condition_note += "covariance could not be computed. ";
    return;
  }
  const Linearization& lin = *w.lin;
  const Eigen::MatrixXd& c = lin.normal_pinv;
  if (lin.dropped_directions > 0) {
    fit->ill_conditioned = true;
    fit->condition_note += fmt::format(
        "rank-deficient Jacobian: some parameters are not determined by these photos ({} direction{} of the "
        "equilibrated J^T J below 1e-12 of its largest eigenvalue); sigmas are from the pseudo-inverse. ",
        lin.dropped_directions, lin.dropped_directions == 1 ? "" : "s");
  }
  const double var = fit->noise_px * fit->noise_px;
  const int nc = static_cast<int>(st.core.size());
  // Curvature: k (or the mean of k(s) over the width, k0 + k2/3, for varying curvature).
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(nc);
  switch (w.kind) {
    case ScreenModelKind::kFlat: break;
    case ScreenModelKind::kVaryingCurvatureQuadratic: grad[2] = 1.0 / 3.0; [[fallthrough]];
    default: grad[0] = 1; break;
  }
  fit->cameras.assign(static_cast<size_t>(setup.photos), CameraEstimate{});
  w.position_curvature_cov.assign(static_cast<size_t>(setup.photos), Eigen::Vector3d::Constant(kNaN));
  for (int p = 0; p < setup.photos; ++p) {
    CameraEstimate& cam = fit->cameras[static_cast<size_t>(p)];
    const PoseBlock& pose = st.poses[static_cast<size_t>(p)];
    cam.centre_from_cam = Pose(Eigen::Quaterniond(pose[3], pose[0], pose[1], pose[2]),
                               Eigen::Vector3d(pose[4], pose[5], pose[6]));
    cam.position_in_centre_mm = cam.centre_from_cam.translation;
    cam.position_in_centre_sigma_mm.setConstant(kNaN);
    const int o = lin.pose_offset[static_cast<size_t>(p)];
    if (o < 0) continue;
    cam.position_in_centre_sigma_mm = (var * c.block<3, 3>(o + 3, o + 3).diagonal()).cwiseSqrt();
    // Tangent space of the pose: rotation (3), then the position (3); the core block is Euclidean.
    if (nc > 0) w.position_curvature_cov[static_cast<size_t>(p)] = var * c.block(o + 3, lin.core_offset, 3, nc) * grad;
  }
  const Eigen::MatrixXd core_cov =
      nc > 0 ? Eigen::MatrixXd(var * c.block(lin.core_offset, lin.core_offset, nc, nc)) : Eigen::MatrixXd();
  if (!st.dev.empty()) {
    const int nd = static_cast<int>(st.dev.size());
    w.dev_covariance = var * c.block(lin.dev_offset, lin.dev_offset, nd, nd);
  }
  if (!st.intr.empty()) JointIntrinsics(setup, st, lin, var, grad, fit);
  if (nc > 0) {
    fit->curvature_per_mm = grad.dot(Eigen::Map<const Eigen::VectorXd>(st.core.data(), nc));
    fit->curvature_sigma_per_mm = std::sqrt(std::max(0.0, grad.dot(core_cov * grad)));
  }
  const auto add_extra = [&](const std::string& name, int i, double scale) {
    fit->extra[name] = {scale * st.core[static_cast<size_t>(i)], scale * std::sqrt(std::max(0.0, core_cov(i, i)))};
  };
  if (w.kind == ScreenModelKind::kCylinderLean) add_extra("lean_deg", 1, kDegPerRad);
  if (w.kind == ScreenModelKind::kVaryingCurvature || w.kind == ScreenModelKind::kVaryingCurvatureQuadratic) {
    add_extra("curvature_centre_per_mm", 0, 1);
    add_extra("k1_per_mm", 1, 1);
    if (w.kind == ScreenModelKind::kVaryingCurvatureQuadratic) add_extra("k2_per_mm", 2, 1);
  }
}

}  // namespace curvecheck::screen_fit_internal
