#include "analysis/screen_fit.h"

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <set>
#include <unordered_map>

#include "analysis/screen_fit_cost.h"
#include "analysis/screen_model.h"
#include "core/error.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"

namespace curvecheck {
namespace {

constexpr double kZ95 = 1.959963984540054;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

using PoseBlock = std::array<double, 7>;  // quaternion x y z w (centre_from_cam), camera position in the centre frame

struct Obs {
  int photo = 0, index = 0;  // photo and index in it
  int feature = 0;           // index of the feature id among all ids
  Eigen::Vector2d uv, detected;
  double s_mm = 0, y_mm = 0;
};

// All parameters of one model: poses and shape.
struct State {
  std::vector<PoseBlock> poses;
  std::vector<double> core;  // CoreParameterCount
  std::vector<double> dev;   // deviation coefficients (cylinder+deviation)
  std::vector<double> intr;  // the lens intrinsics when they are free (FitOptions::fit_intrinsics), else empty
};

struct Setup {
  const Monitor* nominal = nullptr;
  const CameraModel* camera = nullptr;
  // camera's projector, shared by the cost functions; MakeCost uses it only while it belongs to `camera` (a copy
  // of the setup with another camera, as the lens-calibration row makes, gets a projector of its own).
  std::optional<PointProjector> projector;
  const FitOptions* options = nullptr;
  int photos = 0;
  std::vector<Obs> obs;
  std::vector<std::string> feature_ids;
  double half_width_mm = 0;
};

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

// The problem of one model over the active observations. Owns what Ceres does not.
struct BuiltProblem {
  std::unique_ptr<ceres::Problem> problem;
  std::unique_ptr<ceres::LossFunction> loss;
  std::unique_ptr<ceres::Manifold> pose_manifold;
  // The residual blocks in the order added: one per active observation (obs_index: its index in Setup::obs),
  // then the deviation prior (if any). The uncertainty budget's Jacobian rows follow this order.
  std::vector<ceres::ResidualBlockId> blocks;
  std::vector<size_t> obs_index;
};

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


// Everything about one model's fit that the selection and the deviations need beyond ModelFit.
// One candidate's residuals against the lens-model-misfit family (FitOptions::misfit_field_degree), after the
// linearized refit of its own parameters: B~ = (I - J (J^T J)^+ J^T) B over the inliers' stacked coordinates.
// gram = B~^T B~, projected = B~^T r, rss = r^T r, basis_trace = trace(B^T B) of the unprojected fields (per
// coordinate), observations = inliers. Empty (observations 0) when the misfit was not measured.
struct LensFieldProjection {
  Eigen::MatrixXd gram;
  Eigen::VectorXd projected;
  double rss = 0, basis_trace = 0;
  int observations = 0;
};

struct ModelWork {
  ScreenModelKind kind;
  State state;
  std::unique_ptr<DeviationBasis> basis;
  double basis_curvature_per_mm = 0;  // what `basis` was built around
  std::vector<Eigen::Vector2d> robust_residuals;
  Eigen::MatrixXd dev_covariance;  // of the deviation coefficients, scaled by the noise
  // Per photo: the covariance of the camera position (centre frame) with the curvature k (the mean curvature for
  // varying curvature), scaled by the noise; NaN where it could not be computed.
  std::vector<Eigen::Vector3d> position_curvature_cov;
  bool robust_ok = false;
  int robust_iterations = 0;
  LensFieldProjection lens_field;
};

// The free intrinsics' outcome (FitOptions::fit_intrinsics): their values, their covariance (marginal over the poses
// and the shape: a block of the joint covariance), their covariance with the curvature k (grad: dk/dcore) and, per
// photo, the correlation of the focal length fx with the camera's distance from the screen centre |c|.
void JointIntrinsics(const Setup& setup, const State& st, ceres::Covariance& covariance, double var,
                     const Eigen::VectorXd& grad, ModelFit* fit) {
  const int ni = static_cast<int>(st.intr.size()), nc = static_cast<int>(st.core.size());
  fit->intrinsics = st.intr;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> ci(ni, ni);
  if (!covariance.GetCovarianceBlock(st.intr.data(), st.intr.data(), ci.data())) return;
  fit->intrinsics_covariance = var * ci;
  if (nc > 0) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cki(nc, ni);
    if (covariance.GetCovarianceBlock(st.core.data(), st.intr.data(), cki.data())) {
      fit->intrinsics_curvature_cov = var * (grad.transpose() * cki).transpose();
    }
  }
  fit->focal_distance_correlation.assign(static_cast<size_t>(setup.photos), kNaN);
  for (int p = 0; p < setup.photos; ++p) {
    const PoseBlock& pose = st.poses[static_cast<size_t>(p)];
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c6;
    Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> cpi(6, ni);
    if (!covariance.GetCovarianceBlockInTangentSpace(pose.data(), pose.data(), c6.data()) ||
        !covariance.GetCovarianceBlockInTangentSpace(pose.data(), st.intr.data(), cpi.data())) {
      continue;
    }
    const Eigen::Vector3d c(pose[4], pose[5], pose[6]);
    const Eigen::Vector3d u = c.normalized();  // d|c|/dc
    const double var_d = u.dot(c6.bottomRightCorner<3, 3>() * u), cov_df = u.dot(cpi.bottomRows<3>().col(0));
    if (var_d > 0 && ci(0, 0) > 0) {
      fit->focal_distance_correlation[static_cast<size_t>(p)] = cov_df / std::sqrt(var_d * ci(0, 0));
    }
  }
}

void Covariances(const Setup& setup, ModelWork& w, BuiltProblem& b, ModelFit* fit) {
  State& st = w.state;
  std::vector<std::pair<const double*, const double*>> pairs;
  for (PoseBlock& pose : st.poses) {
    if (!b.problem->HasParameterBlock(pose.data())) continue;
    pairs.emplace_back(pose.data(), pose.data());
    // The pose-shape cross block: the screen-frame camera position (z - R) needs cov(position, curvature).
    if (!st.core.empty()) pairs.emplace_back(pose.data(), st.core.data());
    if (!st.intr.empty()) pairs.emplace_back(pose.data(), st.intr.data());
  }
  if (!st.core.empty()) pairs.emplace_back(st.core.data(), st.core.data());
  if (!st.dev.empty()) pairs.emplace_back(st.dev.data(), st.dev.data());
  if (!st.intr.empty()) {
    pairs.emplace_back(st.intr.data(), st.intr.data());
    if (!st.core.empty()) pairs.emplace_back(st.core.data(), st.intr.data());
  }
  ceres::Covariance::Options co;
  co.num_threads = 1;
  co.algorithm_type = ceres::SPARSE_QR;
  auto covariance = std::make_unique<ceres::Covariance>(co);
  bool ok = covariance->Compute(pairs, b.problem.get());
  if (!ok) {
    // Rank-deficient: report it and fall back to the pseudo-inverse (directions below 1e-12 of the largest
    // eigenvalue of J^T J dropped).
    co.algorithm_type = ceres::DENSE_SVD;
    co.null_space_rank = -1;
    co.min_reciprocal_condition_number = 1e-12;
    covariance = std::make_unique<ceres::Covariance>(co);
    ok = covariance->Compute(pairs, b.problem.get());
    fit->ill_conditioned = true;
    fit->condition_note += "rank-deficient Jacobian: some parameters are not determined by these photos; "
                           "sigmas are from the pseudo-inverse. ";
    if (!ok) {
      fit->condition_note += "covariance could not be computed. ";
      return;
    }
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
    cam.position_in_centre_sigma_mm.setConstant(kNaN);
    if (!b.problem->HasParameterBlock(pose.data())) continue;
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c6;
    if (covariance->GetCovarianceBlockInTangentSpace(pose.data(), pose.data(), c6.data())) {
      cam.position_in_centre_sigma_mm = (var * c6.bottomRightCorner<3, 3>().diagonal()).cwiseSqrt();
    }
    if (nc > 0) {
      // Tangent space of the pose: rotation (3), then the position (3); the core block is Euclidean.
      Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> cross(6, nc);
      if (covariance->GetCovarianceBlockInTangentSpace(pose.data(), st.core.data(), cross.data())) {
        w.position_curvature_cov[static_cast<size_t>(p)] = var * cross.bottomRows<3>() * grad;
      }
    }
  }
  Eigen::MatrixXd core_cov = Eigen::MatrixXd::Zero(nc, nc);
  if (nc > 0) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(nc, nc);
    if (covariance->GetCovarianceBlock(st.core.data(), st.core.data(), c.data())) core_cov = var * c;
  }
  if (!st.dev.empty()) {
    const int nd = static_cast<int>(st.dev.size());
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(nd, nd);
    if (covariance->GetCovarianceBlock(st.dev.data(), st.dev.data(), c.data())) w.dev_covariance = var * c;
  }
  if (!st.intr.empty()) JointIntrinsics(setup, st, *covariance, var, grad, fit);
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

// ---- The uncertainty budget (metrology.md section 1; UncertaintyBudget in screen_fit.h). ----
//
// Every source is propagated to the same quantities of interest q = (k, c_1, ..., c_P): the curvature (the mean
// curvature for varying curvature, as reported) and each photo's camera position in the centre frame. A source
// that perturbs the residuals by dr moves the least-squares solution by d(theta) = -(J^T J)^+ J^T dr (the fit's
// linearization at its solution; J in Ceres's tangent space, deviation prior rows included and unperturbed), so
// dq = -G dr with G the rows of the pseudo-inverse of J that belong to q. Each source gives a covariance of q;
// what is kept of it is var(k) and, per photo, var(c) (diagonal) and cov(c, k): all that the radius, its interval
// and the axis-frame position (z - 1/k) need.
struct QuantityVariance {
  double var_k = 0;
  std::vector<Eigen::Vector3d> var_pos, cov_pos_k;

  explicit QuantityVariance(int photos)
      : var_pos(static_cast<size_t>(photos), Eigen::Vector3d::Zero()),
        cov_pos_k(static_cast<size_t>(photos), Eigen::Vector3d::Zero()) {}
  // From a full covariance of q (1 + 3 P rows, as above).
  static QuantityVariance FromCovariance(const Eigen::MatrixXd& c, int photos) {
    QuantityVariance v(photos);
    v.var_k = c(0, 0);
    for (int p = 0; p < photos; ++p) {
      for (int a = 0; a < 3; ++a) {
        v.var_pos[static_cast<size_t>(p)][a] = c(1 + 3 * p + a, 1 + 3 * p + a);
        v.cov_pos_k[static_cast<size_t>(p)][a] = c(1 + 3 * p + a, 0);
      }
    }
    return v;
  }
};

// The linearization of the final fit: G (rows of q, columns the residuals of the active observations, two per
// observation in BuiltProblem order) and the active observations' indices.
struct Linearization {
  Eigen::MatrixXd g;             // (1 + 3 P) x (2 n_obs)
  std::vector<size_t> obs;       // Setup::obs index of each column pair
  Eigen::MatrixXd j_obs;         // (2 n_obs) x t: the observations' rows of J (tangent space)
  Eigen::MatrixXd normal_pinv;   // (J^T J)^+, t x t
};

std::optional<Linearization> Linearize(const Setup& setup, const ModelWork& w, BuiltProblem& b, std::string* note) {
  State& st = const_cast<State&>(w.state);  // Ceres wants non-const blocks; Evaluate does not change them
  ceres::Problem::EvaluateOptions eo;
  eo.residual_blocks = b.blocks;
  eo.num_threads = 1;
  std::vector<int> pose_offset(static_cast<size_t>(setup.photos), -1);
  int t = 0;
  for (int p = 0; p < setup.photos; ++p) {
    double* block = st.poses[static_cast<size_t>(p)].data();
    if (!b.problem->HasParameterBlock(block)) continue;
    eo.parameter_blocks.push_back(block);
    pose_offset[static_cast<size_t>(p)] = t;
    t += 6;  // tangent space: rotation (3), then the position (3)
  }
  const int core_offset = t;
  if (!st.core.empty()) eo.parameter_blocks.push_back(st.core.data()), t += static_cast<int>(st.core.size());
  if (!st.dev.empty()) eo.parameter_blocks.push_back(st.dev.data()), t += static_cast<int>(st.dev.size());
  if (!st.intr.empty()) eo.parameter_blocks.push_back(st.intr.data()), t += static_cast<int>(st.intr.size());
  ceres::CRSMatrix crs;
  if (!b.problem->Evaluate(eo, nullptr, nullptr, nullptr, &crs)) {
    *note += "the Jacobian could not be evaluated; ";
    return std::nullopt;
  }
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int i = crs.rows[static_cast<size_t>(r)]; i < crs.rows[static_cast<size_t>(r) + 1]; ++i) {
      j(r, crs.cols[static_cast<size_t>(i)]) = crs.values[static_cast<size_t>(i)];
    }
  }
  // Selection of q from the tangent parameters.
  const int nq = 1 + 3 * setup.photos;
  Eigen::MatrixXd sel = Eigen::MatrixXd::Zero(nq, t);
  switch (w.kind) {
    case ScreenModelKind::kFlat: break;
    case ScreenModelKind::kVaryingCurvatureQuadratic: sel(0, core_offset + 2) = 1.0 / 3.0; [[fallthrough]];
    default: sel(0, core_offset) = 1; break;
  }
  for (int p = 0; p < setup.photos; ++p) {
    const int o = pose_offset[static_cast<size_t>(p)];
    if (o < 0) continue;
    for (int a = 0; a < 3; ++a) sel(1 + 3 * p + a, o + 3 + a) = 1;
  }
  // G = sel (J^T J)^+ J^T through the small normal matrix (t x t; J has thousands of rows): its pseudo-inverse
  // drops directions below 1e-12 of the largest eigenvalue, as the covariance's fallback does.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(j.transpose() * j);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double cut = 1e-12 * std::max(ev.maxCoeff(), 1e-300);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(ev.size());
  for (long i = 0; i < ev.size(); ++i) inv[i] = ev[i] > cut ? 1 / ev[i] : 0;
  const Eigen::MatrixXd x = eig.eigenvectors() * inv.asDiagonal() * (eig.eigenvectors().transpose() * sel.transpose());
  Linearization lin;
  const Eigen::MatrixXd g_all = x.transpose() * j.transpose();
  const size_t n_obs = b.obs_index.size();
  lin.g = g_all.leftCols(static_cast<long>(2 * n_obs));
  lin.obs = b.obs_index;
  lin.j_obs = j.topRows(static_cast<long>(2 * n_obs));
  lin.normal_pinv = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  return lin;
}

// Bias fields over the image of RMS `bound_px` per coordinate (Legendre polynomials of total degree <= `degree`,
// the same field in every photo), propagated through G; the covariance of q over seeded draws. The detector
// systematic's smooth part and the lens model misfit.
// The active observations' detected positions, in Linearization order.
std::vector<Eigen::Vector2d> DetectedPoints(const Setup& setup, const Linearization& lin) {
  std::vector<Eigen::Vector2d> points;
  for (size_t i : lin.obs) points.push_back(setup.obs[i].detected);
  return points;
}

QuantityVariance SystematicVariance(const Setup& setup, const Linearization& lin, double bound_px,
                                    const Eigen::MatrixXd& basis) {
  const FitOptions& o = *setup.options;
  const int n = static_cast<int>(lin.obs.size()), nq = static_cast<int>(lin.g.rows());
  const long terms = basis.cols();
  // A detection bias delta shifts the residual q - detected by -delta, and q by -G (-delta) = G delta.
  Eigen::MatrixXd gx(nq, n), gy(nq, n);
  for (int i = 0; i < n; ++i) gx.col(i) = lin.g.col(2 * i), gy.col(i) = lin.g.col(2 * i + 1);
  const Eigen::MatrixXd mx = gx * basis, my = gy * basis;
  const Eigen::MatrixXd gram = basis.transpose() * basis;
  std::mt19937_64 rng(o.systematic_field_seed);
  std::normal_distribution<double> unit(0, 1);
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(nq, nq);
  for (int d = 0; d < o.systematic_field_draws; ++d) {
    Eigen::VectorXd ax(terms), ay(terms);
    for (long i = 0; i < terms; ++i) ax[i] = unit(rng), ay[i] = unit(rng);
    const double ms = (ax.dot(gram * ax) + ay.dot(gram * ay)) / (2.0 * n);
    if (!(ms > 0)) continue;
    const Eigen::VectorXd dq = (bound_px / std::sqrt(ms)) * (mx * ax + my * ay);
    cov += dq * dq.transpose();
  }
  return QuantityVariance::FromCovariance(cov / o.systematic_field_draws, setup.photos);
}

// The misfit field's RMS s and correlation length L, from the residuals' correlation at several lags
// (UncertaintyBudget::misfit_length_px, misfit_lags). The neighbour statistic alone cannot tell a field smooth over
// the whole image (which moves the radius) from errors correlated over a few features only (the detector's
// pixel-locking beat, demosaicing, moire: they average out over the board): propagated as a smooth field, the
// latter gave radius sigmas 1.4-3x the scatter of seeded trials (bench validity, realistic camera). Per lag bin j
// (pairs in the same photo at a distance of [0, 1.5), [1.5, 3), [3, 6), [6, 12), [12, 24) feature spacings),
// S_j = mean of r_a . r_b / 2 has E[S_j] = s^2 kappa_j(L) + sigma^2 nu_j: kappa_j the same mean of the stationary
// Gaussian field of unit variance and covariance exp(-d^2 / 2 L^2) after the linearized refit, exactly from its
// random-feature basis Phi (E[e_a . e_b] = (R R^T)_ab, R = (I - J (J^T J)^+ J^T) Phi), nu_j the refit's share
// -(J (J^T J)^+ J^T)_ab. For each L of a grid (1 to 32 feature spacings, at most the image width) s^2 >= 0 is
// fitted by weighted least squares (weights pairs_j / sigma^4: S_j's variance under noise); the L of the smallest
// weighted misfit is kept, with s^2's standard error. Pairs beyond kMaxPairsPerLag per bin are thinned evenly.
void EstimateMisfitCorrelation(const Setup& setup, const Linearization& lin,
                               const std::vector<Eigen::Vector2d>& residual, double sigma_px,
                               const std::vector<std::pair<int, int>>& neighbours, UncertaintyBudget* bud) {
  const FitOptions& o = *setup.options;
  constexpr size_t kMaxPairsPerLag = 6000;
  constexpr std::array<double, 6> kLagEdges = {0, 1.5, 3, 6, 12, 24};
  const int n = static_cast<int>(lin.obs.size());
  const std::vector<Eigen::Vector2d> points = DetectedPoints(setup, lin);
  std::vector<double> nn;
  for (const auto& [a, b] : neighbours) nn.push_back((points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).norm());
  if (nn.size() < 8 || !(sigma_px > 0)) return;
  std::nth_element(nn.begin(), nn.begin() + static_cast<long>(nn.size() / 2), nn.end());
  const double spacing = nn[nn.size() / 2];
  if (!(spacing > 0)) return;
  const size_t bins = kLagEdges.size() - 1;
  std::vector<std::vector<std::pair<int, int>>> lag(bins);
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      if (setup.obs[lin.obs[static_cast<size_t>(a)]].photo != setup.obs[lin.obs[static_cast<size_t>(b)]].photo) continue;
      const double d = (points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).norm() / spacing;
      for (size_t j = 0; j < bins; ++j) {
        if (d >= kLagEdges[j] && d < kLagEdges[j + 1]) lag[j].emplace_back(a, b);
      }
    }
  }
  for (auto& l : lag) {
    if (l.size() <= kMaxPairsPerLag) continue;
    std::vector<std::pair<int, int>> thin;
    const double step = static_cast<double>(l.size()) / kMaxPairsPerLag;
    for (size_t i = 0; i < kMaxPairsPerLag; ++i) thin.push_back(l[static_cast<size_t>(i * step)]);
    l.swap(thin);
  }
  const Eigen::MatrixXd jp = lin.j_obs * lin.normal_pinv;  // 2n x t
  const double s4 = std::pow(sigma_px, 4);
  struct Bin { double lag = 0, stat = 0, nu = 0, weight = 0; int pairs = 0; };
  std::vector<Bin> stats;
  std::vector<size_t> used_bins;
  for (size_t j = 0; j < bins; ++j) {
    if (lag[j].size() < 8) continue;
    Bin bin;
    bin.pairs = static_cast<int>(lag[j].size());
    for (const auto& [a, b] : lag[j]) {
      bin.lag += (points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).norm() / spacing;
      bin.stat += 0.5 * residual[static_cast<size_t>(a)].dot(residual[static_cast<size_t>(b)]);
      for (int c = 0; c < 2; ++c) bin.nu -= 0.5 * jp.row(2 * a + c).dot(lin.j_obs.row(2 * b + c));
    }
    bin.lag /= bin.pairs, bin.stat /= bin.pairs, bin.nu /= bin.pairs;
    bin.weight = bin.pairs / s4;
    stats.push_back(bin);
    used_bins.push_back(j);
  }
  if (stats.size() < 2) return;
  // kappa_j(L) for each length of the grid.
  std::vector<double> lengths;
  std::vector<Eigen::VectorXd> kappas;
  for (double factor : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0}) {
    const double length = std::min(factor * spacing, static_cast<double>(setup.camera->width));
    if (!lengths.empty() && length <= lengths.back()) continue;
    const Eigen::MatrixXd phi = GaussianFieldBasis(points, length, o.misfit_features, o.systematic_field_seed + 2);
    const long d = phi.cols();
    Eigen::MatrixXd dx = Eigen::MatrixXd::Zero(2 * n, d), dy = Eigen::MatrixXd::Zero(2 * n, d);
    for (int i = 0; i < n; ++i) dx.row(2 * i) = phi.row(i), dy.row(2 * i + 1) = phi.row(i);
    const Eigen::MatrixXd rx = dx - jp * (lin.j_obs.transpose() * dx);
    const Eigen::MatrixXd ry = dy - jp * (lin.j_obs.transpose() * dy);
    const double variance = phi.squaredNorm() / n;  // the field's mean variance at the points (1 but for sampling)
    Eigen::VectorXd kappa(static_cast<long>(stats.size()));
    for (size_t k = 0; k < stats.size(); ++k) {
      double sum = 0;
      for (const auto& [a, b] : lag[used_bins[k]]) {
        for (int c = 0; c < 2; ++c) {
          sum += 0.5 * (rx.row(2 * a + c).dot(rx.row(2 * b + c)) + ry.row(2 * a + c).dot(ry.row(2 * b + c)));
        }
      }
      kappa[static_cast<long>(k)] = sum / stats[k].pairs / variance;
    }
    lengths.push_back(length);
    kappas.push_back(kappa);
  }
  // The statistics beyond the noise's share, and their weights: a pair's product has a variance of about
  // (sigma^2 + s^2)^2 / 2 (s^2 from the nearest lag); pairs overlap, so the weights are relative and the standard
  // errors are scaled by the fit's own scatter (Birge ratio) when it exceeds them.
  const long m = static_cast<long>(stats.size());
  Eigen::VectorXd y(m), w(m);
  for (long k = 0; k < m; ++k) y[k] = stats[static_cast<size_t>(k)].stat - sigma_px * sigma_px * stats[static_cast<size_t>(k)].nu;
  const double total = sigma_px * sigma_px + std::max(0.0, y[0]);
  for (long k = 0; k < m; ++k) w[k] = stats[static_cast<size_t>(k)].pairs / (total * total);
  // Non-negative weighted least squares of y on one or two of the kappa vectors (a short- and a long-range
  // component: detector errors correlated over a few features, and the lens's smooth field); the best fit wins,
  // a second component only when it lowers chi^2 by more than 2 (one parameter more, AIC).
  struct Choice {
    double cost = kInf;
    std::vector<std::pair<size_t, double>> parts;  // (length index, variance)
    Eigen::MatrixXd covariance;
  };
  Choice best;
  const auto consider = [&](const std::vector<size_t>& idx) {
    const long p = static_cast<long>(idx.size());
    Eigen::MatrixXd a(m, p);
    for (long c = 0; c < p; ++c) a.col(c) = kappas[idx[static_cast<size_t>(c)]];
    const Eigen::MatrixXd normal = a.transpose() * w.asDiagonal() * a;
    if (normal.determinant() <= 1e-300 * std::pow(normal.norm(), static_cast<double>(p))) return;
    const Eigen::VectorXd x = normal.ldlt().solve(a.transpose() * w.asDiagonal() * y);
    if ((x.array() < 0).any()) return;  // the one-component fits cover the boundary
    const Eigen::VectorXd e = y - a * x;
    const double cost = e.dot(w.asDiagonal() * e) + 2.0 * p;
    if (cost >= best.cost) return;
    best.cost = cost;
    best.parts.clear();
    for (long c = 0; c < p; ++c) best.parts.emplace_back(idx[static_cast<size_t>(c)], x[c]);
    const double birge = m > p ? std::max(1.0, (cost - 2.0 * p) / static_cast<double>(m - p)) : 1.0;
    best.covariance = birge * normal.inverse();
  };
  for (size_t i = 0; i < lengths.size(); ++i) {
    consider({i});
    for (size_t j = i + 1; j < lengths.size() && m > 2; ++j) consider({i, j});
  }
  if (best.parts.empty()) {  // every one-component fit was negative: no correlated error seen
    best.parts = {{lengths.size() - 1, 0.0}};
    const double kw = kappas.back().dot(w.asDiagonal() * kappas.back());
    best.covariance = Eigen::MatrixXd::Constant(1, 1, kw > 0 ? 1 / kw : kInf);
    const Eigen::VectorXd e = y;
    best.cost = e.dot(w.asDiagonal() * e) + 2.0;
  }
  bud->misfit_components.clear();
  Eigen::VectorXd model = Eigen::VectorXd::Zero(m);
  for (size_t c = 0; c < best.parts.size(); ++c) {
    const auto& [li, v] = best.parts[c];
    bud->misfit_components.push_back(
        {lengths[li], v, std::sqrt(std::max(0.0, best.covariance(static_cast<long>(c), static_cast<long>(c))))});
    model += v * kappas[li];
  }
  // The long-range component is the one that moves the radius; the summary fields name it.
  const UncertaintyBudget::FieldComponent& longest = bud->misfit_components.back();
  bud->misfit_length_px = longest.length_px;
  bud->misfit_variance_px2 = longest.variance_px2;
  bud->misfit_variance_sd_px2 = longest.variance_sd_px2;
  bud->misfit_lags.clear();
  for (long k = 0; k < m; ++k) {
    const size_t kk = static_cast<size_t>(k);
    bud->misfit_lags.push_back({stats[kk].lag, stats[kk].pairs, stats[kk].stat, sigma_px * sigma_px * stats[kk].nu, model[k]});
  }
  const double best_cost = best.cost;
  bud->misfit_spacing_px = spacing;
  bud->misfit_fit_chi2 = best_cost;
}

// A stationary Gaussian field of variance s2 px^2 per coordinate and correlation length length_px over the image,
// common to every photo, propagated through G exactly from its random-feature basis: cov(q) = s2 / v (G_x Phi
// Phi^T G_x^T + G_y Phi Phi^T G_y^T), v the basis's mean variance at the points.
QuantityVariance GaussianFieldVariance(const Setup& setup, const Linearization& lin, double s2, double length_px) {
  const FitOptions& o = *setup.options;
  const int n = static_cast<int>(lin.obs.size()), nq = static_cast<int>(lin.g.rows());
  const Eigen::MatrixXd phi =
      GaussianFieldBasis(DetectedPoints(setup, lin), length_px, o.misfit_features, o.systematic_field_seed + 2);
  Eigen::MatrixXd gx(nq, n), gy(nq, n);
  for (int i = 0; i < n; ++i) gx.col(i) = lin.g.col(2 * i), gy.col(i) = lin.g.col(2 * i + 1);
  const Eigen::MatrixXd mx = gx * phi, my = gy * phi;
  const double variance = phi.squaredNorm() / n;
  return QuantityVariance::FromCovariance(s2 / variance * (mx * mx.transpose() + my * my.transpose()), setup.photos);
}

// The lens model misfit's RMS, measured from the residuals (UncertaintyBudget::misfit_*). Each detection is paired
// with its nearest neighbour in the same photo; the statistic S is the mean of r_i . r_j / 2 over the pairs. A
// field smooth on the scale of the feature spacing is nearly equal at both, independent noise is not, so
// E[S] = s^2 kappa + sigma^2 nu: kappa is the mean of S over unit-RMS fields of the assumed family after the
// linearized refit, r = (I - J (J^T J)^+ J^T) dr (seeded draws), and nu the noise's own share, the mean over the
// pairs of -(J (J^T J)^+ J^T)_ij (the refit correlates the residuals slightly). Under noise alone S has a standard
// deviation of about sigma^2 / sqrt(pairs) (products of independent Gaussians, pairs counted once); the bound
// is (S - sigma^2 nu + 2 sd) / kappa.
void EstimateMisfit(const Setup& setup, const Linearization& lin, const std::vector<Eigen::Vector2d>& residual,
                    double sigma_px, UncertaintyBudget* bud, LensFieldProjection* projection) {
  const FitOptions& o = *setup.options;
  const int n = static_cast<int>(lin.obs.size());
  if (n < 8 || static_cast<int>(residual.size()) != n) return;
  // Candidates per photo (in ascending order, so the first of equally near neighbours wins, as in one pass over all).
  std::vector<std::vector<int>> in_photo(static_cast<size_t>(setup.photos));
  for (int a = 0; a < n; ++a) in_photo[static_cast<size_t>(setup.obs[lin.obs[static_cast<size_t>(a)]].photo)].push_back(a);
  std::vector<std::pair<int, int>> pairs;
  for (int a = 0; a < n; ++a) {
    const Obs& oa = setup.obs[lin.obs[static_cast<size_t>(a)]];
    int best = -1;
    double best_d2 = kInf;
    for (const int b : in_photo[static_cast<size_t>(oa.photo)]) {
      if (b == a) continue;
      const double d2 = (setup.obs[lin.obs[static_cast<size_t>(b)]].detected - oa.detected).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = b;
    }
    if (best >= 0) pairs.emplace_back(a, best);
  }
  if (pairs.size() < 8) return;
  const double np = static_cast<double>(pairs.size());
  double stat = 0, nu = 0;
  const Eigen::MatrixXd j_pinv = lin.j_obs * lin.normal_pinv;  // one product instead of one per pair
  for (const auto& [a, b] : pairs) {
    stat += 0.5 * residual[static_cast<size_t>(a)].dot(residual[static_cast<size_t>(b)]) / np;
    for (int c = 0; c < 2; ++c) nu -= 0.5 * j_pinv.row(2 * a + c).dot(lin.j_obs.row(2 * b + c)) / np;
  }
  // kappa over seeded unit-RMS fields of the family, through the refit.
  const Eigen::MatrixXd basis = LegendreFieldBasis(DetectedPoints(setup, lin), setup.camera->width,
                                                   setup.camera->height, o.misfit_field_degree);
  const long terms = basis.cols();
  Eigen::MatrixXd dx = Eigen::MatrixXd::Zero(2 * n, terms), dy = Eigen::MatrixXd::Zero(2 * n, terms);
  for (int i = 0; i < n; ++i) dx.row(2 * i) = basis.row(i), dy.row(2 * i + 1) = basis.row(i);
  const Eigen::MatrixXd rx = dx - lin.j_obs * (lin.normal_pinv * (lin.j_obs.transpose() * dx));
  const Eigen::MatrixXd ry = dy - lin.j_obs * (lin.normal_pinv * (lin.j_obs.transpose() * dy));
  const Eigen::MatrixXd gram = basis.transpose() * basis;
  {
    Eigen::MatrixXd projected_basis(2 * n, 2 * terms);
    projected_basis << rx, ry;
    Eigen::VectorXd r(2 * n);
    for (int i = 0; i < n; ++i) r.segment<2>(2 * i) = residual[static_cast<size_t>(i)];
    if (r.allFinite()) {
      projection->gram = projected_basis.transpose() * projected_basis;
      projection->projected = projected_basis.transpose() * r;
      projection->rss = r.squaredNorm();
      projection->basis_trace = gram.trace();
      projection->observations = n;
    }
  }
  // The statistic of a field's residual e = rx ax + ry ay is a quadratic form in (ax, ay): the pairs' sum
  // 0.5/np sum (e_2a e_2b + e_2a+1 e_2b+1) = (ax, ay)^T pair_form (ax, ay), pair_form = 0.5/np R_a^T R_b with R_a,
  // R_b the rows of [rx ry] at the pairs' first and second members; formed once instead of once per draw.
  Eigen::MatrixXd rows_a(2 * pairs.size(), 2 * terms), rows_b(2 * pairs.size(), 2 * terms);
  for (size_t k = 0; k < pairs.size(); ++k) {
    for (int c = 0; c < 2; ++c) {
      rows_a.row(static_cast<long>(2 * k) + c) << rx.row(2 * pairs[k].first + c), ry.row(2 * pairs[k].first + c);
      rows_b.row(static_cast<long>(2 * k) + c) << rx.row(2 * pairs[k].second + c), ry.row(2 * pairs[k].second + c);
    }
  }
  const Eigen::MatrixXd pair_form = (0.5 / np) * (rows_a.transpose() * rows_b);
  std::mt19937_64 rng(o.systematic_field_seed + 1);
  std::normal_distribution<double> unit(0, 1);
  double kappa = 0;
  const int draws = 400;
  int used = 0;
  for (int d = 0; d < draws; ++d) {
    Eigen::VectorXd ax(terms), ay(terms);
    for (long i = 0; i < terms; ++i) ax[i] = unit(rng), ay[i] = unit(rng);
    const double ms = (ax.dot(gram * ax) + ay.dot(gram * ay)) / (2.0 * n);
    if (!(ms > 0)) continue;
    Eigen::VectorXd a(2 * terms);
    a << ax, ay;
    kappa += a.dot(pair_form * a) / ms;
    ++used;
  }
  if (used == 0) return;
  kappa /= used;
  const double noise_share = sigma_px * sigma_px * nu;
  const double sd_stat = sigma_px * sigma_px / std::sqrt(np);
  bud->misfit_statistic_px2 = stat;
  bud->misfit_noise_share_px2 = noise_share;
  bud->misfit_kappa = kappa;
  bud->misfit_pairs = static_cast<int>(pairs.size());
  if (!(kappa > 1e-6)) return;  // the family is invisible in the residuals: nothing can be measured
  bud->misfit_estimate_px = std::sqrt(std::max(0.0, stat - noise_share) / kappa);
  bud->misfit_bound_px = std::sqrt(std::max(0.0, stat - noise_share + 2 * sd_stat) / kappa);
  EstimateMisfitCorrelation(setup, lin, residual, sigma_px, pairs, bud);
}

// Pixel-locking itself, propagated in its own shape: per coordinate c a bias A_c sin(2 pi phi_i + psi) with phi_i
// the detection's subpixel phase, A_c the bound (estimate + 2 sigma) and the phase offset psi unknown (uniform):
// dq = A_c (G s_c cos psi + G c_c sin psi), s_c = sin 2 pi phi, c_c = cos 2 pi phi, whose covariance over psi is
// A_c^2 / 2 (G s_c s_c^T G^T + G c_c c_c^T G^T). On a regular board the phases beat across the image, so this
// field is correlated in a way that low-order smooth fields do not represent.
QuantityVariance PixelLockingVariance(const Setup& setup, const Linearization& lin, const Eigen::Vector2d& bound_px) {
  constexpr double kTwoPi = 6.283185307179586;
  const int n = static_cast<int>(lin.obs.size()), nq = static_cast<int>(lin.g.rows());
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(nq, nq);
  for (int c = 0; c < 2; ++c) {
    if (!std::isfinite(bound_px[c]) || !(bound_px[c] > 0)) continue;
    Eigen::VectorXd sv = Eigen::VectorXd::Zero(2 * n), cv = Eigen::VectorXd::Zero(2 * n);
    for (int i = 0; i < n; ++i) {
      const double q = setup.obs[lin.obs[static_cast<size_t>(i)]].detected[c];
      const double phase = kTwoPi * (q - std::floor(q));
      sv[2 * i + c] = std::sin(phase);
      cv[2 * i + c] = std::cos(phase);
    }
    const Eigen::VectorXd gs = lin.g * sv, gc = lin.g * cv;
    cov += 0.5 * bound_px[c] * bound_px[c] * (gs * gs.transpose() + gc * gc.transpose());
  }
  return QuantityVariance::FromCovariance(cov, setup.photos);
}

// Lens calibration: dq/d(intrinsics) by central differences of the residuals at the fitted parameters (the
// linearized refit), then S Sigma S^T.
QuantityVariance LensVariance(const Setup& setup, const ModelWork& w, const Linearization& lin) {
  const Eigen::MatrixXd& sigma = setup.options->intrinsics_covariance;
  const int ni = static_cast<int>(setup.camera->intrinsics.size()), n = static_cast<int>(lin.obs.size());
  Eigen::MatrixXd s(lin.g.rows(), ni);
  for (int k = 0; k < ni; ++k) {
    const double c = setup.camera->intrinsics[static_cast<size_t>(k)];
    const double h = 1e-6 * std::max(std::abs(c), 1.0);
    std::array<std::vector<Eigen::Vector2d>, 2> d;
    for (int side = 0; side < 2; ++side) {
      CameraModel cam = *setup.camera;
      cam.intrinsics[static_cast<size_t>(k)] = c + (side == 0 ? h : -h);
      Setup perturbed = setup;
      perturbed.camera = &cam;
      d[static_cast<size_t>(side)] = Residuals(perturbed, w.kind, w.basis.get(), w.state);
    }
    // d = detected - q; q moves by -(d+ - d-)/2h per unit; the solution moves by -G dq... = G (d+ - d-)/2h.
    Eigen::VectorXd dd(2 * n);
    for (int i = 0; i < n; ++i) {
      const size_t oi = lin.obs[static_cast<size_t>(i)];
      const Eigen::Vector2d v = (d[0][oi] - d[1][oi]) / (2 * h);
      dd[2 * i] = v.allFinite() ? v.x() : 0;
      dd[2 * i + 1] = v.allFinite() ? v.y() : 0;
    }
    s.col(k) = lin.g * dd;
  }
  return QuantityVariance::FromCovariance(s * sigma * s.transpose(), setup.photos);
}

std::string Percent(double relative) { return fmt::format("{:.3g}%", 100 * relative); }

// Builds the budget of one candidate at its final solution and replaces its sigmas by the combined ones (the
// curvature's, the cameras' centre-frame positions and their covariance with k). Returns the components'
// variances for FinishBudget, which fills the radius and axis-frame columns once the radius is known.
std::vector<QuantityVariance> Budget(const Setup& setup, ModelWork& w, BuiltProblem& b, int n_residuals,
                                     ModelFit* fit) {
  const FitOptions& o = *setup.options;
  UncertaintyBudget& bud = fit->budget;
  bud.coverage_probability = o.coverage_probability;
  std::vector<QuantityVariance> vars;
  // 1. Detection noise: the covariance scaled by the residual noise (Covariances).
  QuantityVariance noise(setup.photos);
  noise.var_k = fit->curvature_sigma_per_mm * fit->curvature_sigma_per_mm;
  for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
    noise.var_pos[static_cast<size_t>(p)] = fit->cameras[static_cast<size_t>(p)].position_in_centre_sigma_mm.cwiseAbs2();
    noise.cov_pos_k[static_cast<size_t>(p)] = w.position_curvature_cov[static_cast<size_t>(p)];
  }
  fit->curvature_noise_sigma_per_mm = fit->curvature_sigma_per_mm;
  BudgetComponent c_noise;
  c_noise.name = "detection noise";
  c_noise.type = "A";
  c_noise.dof = std::max(1, n_residuals - fit->parameters);
  c_noise.source = fmt::format(
      "the fit's covariance (J^T J)^-1 scaled by its residual noise {:.4f} px per coordinate ({} residuals, {} "
      "parameters)",
      fit->noise_px, n_residuals, fit->parameters);
  c_noise.assumption = "independent, isotropic Gaussian detection errors; the residual scatter measures them";
  bud.components.push_back(c_noise);
  vars.push_back(noise);

  const std::optional<Linearization> lin = Linearize(setup, w, b, &bud.note);
  // 2. Detector systematic (pixel-locking and other detector bias).
  {
    std::vector<Eigen::Vector2d> det, res;
    if (lin) {
      for (size_t i : lin->obs) {
        det.push_back(setup.obs[i].detected);
        res.push_back(fit->residual_px[static_cast<size_t>(setup.obs[i].photo)][static_cast<size_t>(setup.obs[i].index)]);
      }
    }
    bud.pixel_locking = EstimatePixelLocking(det, res);
    const ResidualPixelLocking& pl = bud.pixel_locking;
    double upper = 0;
    for (int c = 0; c < 2; ++c) {
      if (std::isfinite(pl.amplitude_px[c])) upper = std::max(upper, pl.amplitude_px[c] + 2 * pl.sigma_px[c]);
    }
    bud.systematic_bound_px = o.smooth_bias_px;
    bud.systematic_bound_reason = fmt::format(
        "the stated smooth detector bias FitOptions::smooth_bias_px (type B, not measured); the pixel-locking "
        "signature's amplitude is its estimate plus 2 sigma, {:.4f} px (x {:.4f} +- {:.4f}, y {:.4f} +- {:.4f} px)",
        upper, pl.amplitude_px.x(), pl.sigma_px.x(), pl.amplitude_px.y(), pl.sigma_px.y());
    BudgetComponent c;
    c.name = "detector systematic";
    c.type = "B";
    c.source = fmt::format(
        "a bias field of RMS b = {:.4f} px per coordinate (b = {}), propagated through the fit's linearization",
        bud.systematic_bound_px, bud.systematic_bound_reason);
    c.assumption = fmt::format(
        "the detector's bias (pixel-locking, moire, corner shape) is smooth across the image and common to every "
        "photo: Legendre fields of total degree <= {} with independent N(0,1) coefficients per coordinate, each "
        "scaled to RMS b ({} seeded draws); its standard uncertainty is the RMS effect. Correlated across features, "
        "unlike the noise row (independent per-feature errors are in that row already); plus, in quadrature, the "
        "pixel-locking signature in its own shape: A sin(2 pi phase + psi) per coordinate at each detection's "
        "subpixel phase, A = the estimate + 2 sigma, psi uniform (on a regular board the phases beat across the "
        "image: a correlated field that smooth fields do not represent)",
        o.systematic_field_degree, o.systematic_field_draws);
    bud.components.push_back(c);
    QuantityVariance v(setup.photos);
    if (lin && (bud.systematic_bound_px > 0 || upper > 0)) {
      // Two parts in quadrature: smooth bias fields of RMS b, and the pixel-locking signature in its own shape.
      Eigen::Vector2d pl_bound = pl.amplitude_px + 2 * pl.sigma_px;
      const QuantityVariance smooth = SystematicVariance(
          setup, *lin, bud.systematic_bound_px,
          LegendreFieldBasis(DetectedPoints(setup, *lin), setup.camera->width, setup.camera->height,
                             o.systematic_field_degree));
      const QuantityVariance locking = PixelLockingVariance(setup, *lin, pl_bound);
      v.var_k = smooth.var_k + locking.var_k;
      for (int p = 0; p < setup.photos; ++p) {
        v.var_pos[static_cast<size_t>(p)] = smooth.var_pos[static_cast<size_t>(p)] + locking.var_pos[static_cast<size_t>(p)];
        v.cov_pos_k[static_cast<size_t>(p)] =
            smooth.cov_pos_k[static_cast<size_t>(p)] + locking.cov_pos_k[static_cast<size_t>(p)];
      }
      bud.pixel_locking_share_curvature_per_mm = std::sqrt(std::max(0.0, locking.var_k));
      bud.smooth_share_curvature_per_mm = std::sqrt(std::max(0.0, smooth.var_k));
    }
    vars.push_back(v);
  }
  // 3. Lens calibration.
  {
    BudgetComponent c;
    c.name = "lens calibration";
    c.type = "A";
    if (o.fit_intrinsics) {
      c.source = "none beyond the detection noise row: the intrinsics are estimated jointly with the poses and the "
                 "screen, so that row's covariance (the joint one, marginalised over the intrinsics) holds the lens's "
                 "uncertainty";
      c.assumption = "the lens model is adequate (its misfit is the lens model misfit row)";
      vars.push_back(QuantityVariance(setup.photos));
    } else if (o.intrinsics_covariance.size() > 0 && lin) {
      c.dof = o.intrinsics_covariance_dof;
      c.source = fmt::format(
          "the calibration's intrinsics covariance ({}) propagated by the linearized refit: dq/d(intrinsics) from "
          "central differences of the residuals, times (J^T J)^-1 J^T",
          o.intrinsics_covariance_source.empty() ? "given" : o.intrinsics_covariance_source);
      c.assumption = "the calibration's own covariance (mrcal: observed pixel noise times (J^T J)^-1, intrinsics "
                     "block); linear in the intrinsics; the same lens for every photo";
      vars.push_back(LensVariance(setup, w, *lin));
    } else {
      c.source = "none";
      c.assumption = o.lens_exact_note;
      vars.push_back(QuantityVariance(setup.photos));
    }
    bud.components.push_back(c);
  }
  // 4. Lens model misfit, measured from the residuals' correlation between neighbours.
  {
    BudgetComponent c;
    c.name = "lens model misfit";
    c.type = "A";
    QuantityVariance v(setup.photos);
    if (lin && o.measure_lens_misfit) {
      std::vector<Eigen::Vector2d> res;
      for (size_t i : lin->obs) {
        res.push_back(fit->residual_px[static_cast<size_t>(setup.obs[i].photo)][static_cast<size_t>(setup.obs[i].index)]);
      }
      EstimateMisfit(setup, *lin, res, fit->noise_px, &bud, &w.lens_field);
    }
    if (!bud.misfit_components.empty()) {
      std::string lags, parts;
      for (const UncertaintyBudget::Lag& l : bud.misfit_lags) {
        lags += fmt::format("{}{:.1f}: {:.3g} (noise {:.3g}, field {:.3g})", lags.empty() ? "" : "; ", l.lag_spacings,
                            l.statistic_px2, l.noise_share_px2, l.field_share_px2);
      }
      double var_sum = 0, dof_denominator = 0;
      for (const UncertaintyBudget::FieldComponent& f : bud.misfit_components) {
        parts += fmt::format("{}RMS {:.4f} px per coordinate (variance {:.3g} +- {:.3g} px^2) at a correlation "
                             "length of {:.0f} px",
                             parts.empty() ? "" : ", plus ", std::sqrt(f.variance_px2), f.variance_px2,
                             f.variance_sd_px2, f.length_px);
        if (!(f.variance_px2 > 0)) continue;
        const QuantityVariance part = GaussianFieldVariance(setup, *lin, f.variance_px2, f.length_px);
        v.var_k += part.var_k;
        for (int p = 0; p < setup.photos; ++p) {
          v.var_pos[static_cast<size_t>(p)] += part.var_pos[static_cast<size_t>(p)];
          v.cov_pos_k[static_cast<size_t>(p)] += part.cov_pos_k[static_cast<size_t>(p)];
        }
        var_sum += part.var_k;
        const double ratio = f.variance_sd_px2 > 0 ? f.variance_px2 / f.variance_sd_px2 : kInf;
        if (std::isfinite(ratio)) dof_denominator += part.var_k * part.var_k / (2 * ratio * ratio);
      }
      if (dof_denominator > 0) c.dof = var_sum * var_sum / dof_denominator;
      c.source = fmt::format(
          "the residuals' correlation at several lags (in feature spacings of {:.1f} px: mean r_a . r_b / 2 in px^2, "
          "{}), fitted by Gaussian fields: {}; propagated through the fit's linearization",
          bud.misfit_spacing_px, lags, parts);
    } else if (!o.measure_lens_misfit) {
      c.source = "none: not measured (FitOptions::measure_lens_misfit off; the lens taken as exact beyond its "
                 "calibration)";
    } else {
      c.source = "not measurable here (too few features or pairs)";
    }
    c.assumption = fmt::format(
        "the true lens departs from its model by a stationary Gaussian field over the image (covariance s^2 "
        "exp(-d^2 / 2 L^2), {} random Fourier features), independent per coordinate and common to every photo; "
        "s and L are those that reproduce the residuals' correlation at 1 to 24 feature spacings after the fit "
        "(the part the fit absorbs into the poses and the screen is inferred from the part it leaves, in the same "
        "family). Any other error correlated between features (detector bias that varies with the image position, "
        "moire) is measured here too, so it may be counted twice with the detector row: conservative. Degrees of "
        "freedom 2 (s^2 / u(s^2))^2",
        o.misfit_features);
    bud.components.push_back(c);
    vars.push_back(v);
  }
  // 5. Pixel pitch: the scene scales with the pitch (R and every position proportional to it, k inversely).
  {
    const double u = o.pitch_tolerance_relative / std::sqrt(3.0);
    QuantityVariance v(setup.photos);
    const double k = fit->curvature_per_mm;
    v.var_k = k * k * u * u;
    for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
      const Eigen::Vector3d c = fit->cameras[static_cast<size_t>(p)].centre_from_cam.translation;
      v.var_pos[static_cast<size_t>(p)] = c.cwiseAbs2() * u * u;
      v.cov_pos_k[static_cast<size_t>(p)] = -c * k * u * u;
    }
    BudgetComponent c;
    c.name = "pixel pitch";
    c.type = "B";
    c.source = fmt::format("the datasheet's pixel pitch {:.5f} mm with a tolerance of +-{} (rectangular: u = {}/sqrt(3) "
                           "= {})",
                           setup.nominal->pixel_pitch_mm(), Percent(o.pitch_tolerance_relative),
                           Percent(o.pitch_tolerance_relative), Percent(u));
    c.assumption = "scale is not observable from photos: R and the distances scale with the pitch, u(R)/R = u(p)/p";
    bud.components.push_back(c);
    vars.push_back(v);
  }
  // Combined, fully in quadrature (the sources are independent; within a source the correlation of k with the
  // positions is kept).
  QuantityVariance total(setup.photos);
  for (const QuantityVariance& v : vars) {
    total.var_k += v.var_k;
    for (int p = 0; p < setup.photos; ++p) {
      total.var_pos[static_cast<size_t>(p)] += v.var_pos[static_cast<size_t>(p)];
      total.cov_pos_k[static_cast<size_t>(p)] += v.cov_pos_k[static_cast<size_t>(p)];
    }
  }
  // Welch-Satterthwaite on u(k).
  double denom = 0;
  for (size_t i = 0; i < vars.size(); ++i) {
    if (std::isfinite(bud.components[i].dof)) denom += vars[i].var_k * vars[i].var_k / bud.components[i].dof;
  }
  bud.effective_dof = denom > 0 ? total.var_k * total.var_k / denom : kInf;
  bud.coverage_factor = StudentTCoverageFactor(o.coverage_probability, std::max(1.0, bud.effective_dof));
  bud.computed = true;
  vars.push_back(total);
  fit->curvature_sigma_per_mm = std::sqrt(std::max(0.0, total.var_k));
  for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
    fit->cameras[static_cast<size_t>(p)].position_in_centre_sigma_mm =
        total.var_pos[static_cast<size_t>(p)].cwiseMax(0.0).cwiseSqrt();
    w.position_curvature_cov[static_cast<size_t>(p)] = total.cov_pos_k[static_cast<size_t>(p)];
  }
  return vars;
}

// The radius and first-camera columns of each row, once the radius is known (RadiusFromCurvature); vars from
// Budget, the combined last. The dominant row is the largest u(k) (and, per axis, the largest position u).
void FinishBudget(const std::vector<QuantityVariance>& vars, ModelFit* fit) {
  UncertaintyBudget& bud = fit->budget;
  if (!bud.computed) return;
  const double k = fit->curvature_per_mm;
  const bool radius = fit->radius_mm.has_value();
  const auto fill = [&](const QuantityVariance& v, BudgetComponent* c) {
    c->curvature_per_mm = std::sqrt(std::max(0.0, v.var_k));
    c->radius_mm = radius ? c->curvature_per_mm / (k * k) : kNaN;
    if (v.var_pos.empty()) return;
    c->position_in_centre_mm = v.var_pos[0].cwiseMax(0.0).cwiseSqrt();
    c->position_in_axis_mm = c->position_in_centre_mm;
    if (radius) {
      // z_axis = c_z - 1/k: var = var(c_z) + var(k)/k^4 + 2 cov(c_z, k)/k^2.
      const double k2 = k * k;
      c->position_in_axis_mm.z() =
          std::sqrt(std::max(0.0, v.var_pos[0].z() + v.var_k / (k2 * k2) + 2 * v.cov_pos_k[0].z() / k2));
    }
  };
  for (size_t i = 0; i < bud.components.size(); ++i) fill(vars[i], &bud.components[i]);
  bud.combined.name = "combined";
  bud.combined.type = "";
  bud.combined.dof = bud.effective_dof;
  bud.combined.source = "quadrature sum of the rows";
  bud.combined.assumption = "the sources are independent of one another";
  fill(vars.back(), &bud.combined);
  size_t best = 0;
  for (size_t i = 1; i < bud.components.size(); ++i) {
    if (bud.components[i].curvature_per_mm > bud.components[best].curvature_per_mm) best = i;
  }
  bud.dominant = bud.components[best].name;
  for (int a = 0; a < 3; ++a) {
    size_t bp = 0;
    for (size_t i = 1; i < bud.components.size(); ++i) {
      if (bud.components[i].position_in_axis_mm[a] > bud.components[bp].position_in_axis_mm[a]) bp = i;
    }
    bud.dominant_position[static_cast<size_t>(a)] = bud.components[bp].name;
  }
}

// Radius, its interval and the screen-frame camera positions from the curvature and its sigma.
void RadiusFromCurvature(const Setup& setup, const ModelWork& w, ModelFit* fit) {
  const double k = fit->curvature_per_mm, sk = fit->curvature_sigma_per_mm;
  const bool curved_model = fit->model != "flat";
  // The interval from the combined standard uncertainty and its coverage factor (the normal 1.96 without a
  // budget).
  const double cover = fit->budget.computed ? fit->budget.coverage_factor : kZ95;
  const double lo = k - cover * sk, hi = k + cover * sk;
  const double max_relative = setup.options->max_relative_curvature_sigma;
  if (curved_model && (lo > 0 || hi < 0) && sk > max_relative * std::abs(k)) {
    // Significantly curved, but too poorly determined for a number. The bound is on |R| (a size, never below
    // zero), from the curvature interval's end farthest from flat; for a curvature of the other sign (a convex fit)
    // 1/lo and 1/hi are negative and would print as "lower bound -5503 mm".
    fit->radius_ci95_mm = {std::min(1 / lo, 1 / hi), std::max(1 / lo, 1 / hi)};
    fit->radius_lower_bound_mm = 1 / std::max(std::abs(lo), std::abs(hi));
    fit->ill_conditioned = true;
    fit->condition_note += fmt::format(
        "radius unobservable from these photos: the curvature {:.3g} +- {:.3g} /m has a relative sigma of {:.0f}% "
        "(limit {:.0f}%), a 95% interval of R from {:.0f} to {:.0f} mm: the radius is not determined by these "
        "photos; take more photos from other positions (closer, and from the sides). ",
        k * 1000, sk * 1000, 100 * sk / std::abs(k), 100 * max_relative, fit->radius_ci95_mm[0],
        fit->radius_ci95_mm[1]);
  } else if (curved_model && (lo > 0 || hi < 0)) {
    fit->radius_mm = 1 / k;
    fit->radius_sigma_mm = sk / (k * k);
    fit->radius_ci95_mm = {std::min(1 / lo, 1 / hi), std::max(1 / lo, 1 / hi)};
  } else if (curved_model) {
    fit->radius_lower_bound_mm = 1 / std::max(std::abs(lo), std::abs(hi));
    fit->radius_ci95_mm = {fit->radius_lower_bound_mm, kInf};
    const double k_nominal = setup.nominal->curvature_per_mm;
    if (k_nominal != 0 && lo <= k_nominal && k_nominal <= hi) {
      fit->ill_conditioned = true;
      fit->condition_note += fmt::format(
          "radius unobservable from these photos: the 95% interval of the curvature [{:.3g}, {:.3g}] /m holds both "
          "flat and the nominal {:.0f} mm; photograph from closer or more obliquely. ",
          lo * 1000, hi * 1000, 1 / k_nominal);
    }
  }
  for (size_t p = 0; p < fit->cameras.size(); ++p) {
    CameraEstimate& cam = fit->cameras[p];
    cam.position_in_screen_mm = cam.centre_from_cam.translation;
    cam.position_in_screen_sigma_mm = cam.position_in_centre_sigma_mm;
    if (!fit->radius_mm) continue;
    // z_screen = c_z - R with R = 1/k: dR/dk = -1/k^2, so var = var(c_z) + var(k)/k^4 + 2 cov(c_z, k)/k^2.
    cam.position_in_screen_mm.z() -= *fit->radius_mm;
    const double k2 = k * k, cov_zk = w.position_curvature_cov[p].z();
    const double sz = cam.position_in_centre_sigma_mm.z();
    cam.position_in_screen_sigma_mm.z() =
        std::sqrt(std::max(0.0, sz * sz + sk * sk / (k2 * k2) + 2 * cov_zk / k2));
  }
}

// The detection noise the candidates are tested against, and the residual noise a model may reach.
double DetectionSigma(const FitOptions& o) {
  return o.detection_noise_px > 0 ? o.detection_noise_px : o.expected_noise_px;
}
double AdequacyLimit(const FitOptions& o) {
  const double sigma = DetectionSigma(o);
  return std::max(o.adequacy_noise_ratio * sigma, sigma + o.noise_floor_px);
}

// The goodness-of-fit test of one candidate (FitOptions::adequacy_p_value) over its inliers' residual sum.
// rss: the plain residual sum, or the one left after the lens model misfit (AdjustForLensField; `what` says so).
void Adequacy(const FitOptions& o, double rss, int n, ModelFit* fit, const std::string& what = "") {
  const double sigma = DetectionSigma(o);
  fit->dof = n - fit->parameters;
  fit->chi2 = rss / (sigma * sigma);
  fit->chi2_p_value = ChiSquareUpperTail(fit->chi2, fit->dof);  // NaN without degrees of freedom: not testable
  const double noise = std::sqrt(rss / std::max(1, fit->dof));   // noise_px for the plain sum
  fit->noise_ratio = noise / sigma;
  const double limit = AdequacyLimit(o);
  fit->adequate = !(fit->chi2_p_value < o.adequacy_p_value && noise > limit);
  fit->adequacy_note.clear();
  if (!fit->adequate) {
    fit->adequacy_note = fmt::format(
        "residual noise {:.3f} px per coordinate{} (RMS {:.3f} px), {:.2f} times the detection noise {:.3f} px "
        "(limit {:.3f} px); chi2/dof = {:.4g}/{} = {:.3g}, p = {:.2g}",
        noise, what, fit->rms_px, fit->noise_ratio, sigma, limit, fit->chi2, fit->dof, fit->chi2 / fit->dof,
        fit->chi2_p_value);
  }
}

// Fits one model: robust pass (outlier flags for the common set), then called again by FitFinal.
void FitRobust(const Setup& setup, ModelWork& w, const std::vector<bool>& active) {
  BuiltProblem b = Build(setup, w.kind, w.basis.get(), active, true, &w.state);
  const ceres::Solver::Summary s = Solve(setup, b, &w.state);
  w.robust_ok = s.IsSolutionUsable();
  w.robust_iterations = static_cast<int>(s.iterations.size());
  w.robust_residuals = Residuals(setup, w.kind, w.basis.get(), w.state);
}

void FitFinal(const Setup& setup, ModelWork& w, const std::vector<bool>& inlier, ModelFit* fit) {
  BuiltProblem b = Build(setup, w.kind, w.basis.get(), inlier, false, &w.state);
  const ceres::Solver::Summary s = Solve(setup, b, &w.state);
  fit->converged = s.termination_type == ceres::CONVERGENCE;
  fit->iterations = w.robust_iterations + static_cast<int>(s.iterations.size());
  if (!fit->converged) {
    fit->condition_note += fmt::format("solver: {} after {} iterations. ", s.message, s.iterations.size());
  }
  const std::vector<Eigen::Vector2d> r = Residuals(setup, w.kind, w.basis.get(), w.state);
  double rss = 0;
  int n_in = 0;
  fit->residual_px.assign(static_cast<size_t>(setup.photos), {});
  fit->outlier.assign(static_cast<size_t>(setup.photos), {});
  for (size_t i = 0; i < setup.obs.size(); ++i) {
    fit->residual_px[static_cast<size_t>(setup.obs[i].photo)].push_back(r[i]);
    fit->outlier[static_cast<size_t>(setup.obs[i].photo)].push_back(!inlier[i]);
    if (inlier[i] && r[i].allFinite()) {
      rss += r[i].squaredNorm();
      ++n_in;
    }
  }
  const int n = 2 * n_in;
  fit->parameters = static_cast<int>(w.state.core.size() + w.state.dev.size() + w.state.intr.size()) + 6 * setup.photos;
  fit->rms_px = std::sqrt(rss / std::max(1, n_in));
  fit->noise_px = std::sqrt(rss / std::max(1, n - fit->parameters));
  // BIC with the residual sum floored at the detections' systematic error (FitOptions::noise_floor_px).
  const double floor_rss = n * setup.options->noise_floor_px * setup.options->noise_floor_px;
  fit->bic = n * std::log(std::max({rss, floor_rss, 1e-300}) / n) +
             fit->parameters * std::log(static_cast<double>(n));
  fit->shape = w.state.core;
  fit->shape.insert(fit->shape.end(), w.state.dev.begin(), w.state.dev.end());
  fit->deviation_basis_curvature_per_mm = w.basis ? w.basis_curvature_per_mm : 0;
  Covariances(setup, w, b, fit);
  std::vector<QuantityVariance> budget_vars;
  if (fit->cameras.size() == static_cast<size_t>(setup.photos)) budget_vars = Budget(setup, w, b, n, fit);
  RadiusFromCurvature(setup, w, fit);
  FinishBudget(budget_vars, fit);
  Adequacy(*setup.options, rss, n, fit);
}

// k-fold over feature ids: refit without each fold (from the full solution), predict the fold.
double HeldOut(const Setup& setup, const ModelWork& w, const std::vector<bool>& inlier) {
  const int folds = setup.options->heldout_folds;
  if (folds < 2) return kNaN;
  std::vector<int> order(setup.feature_ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(20261122);  // fixed: the same folds for every model
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<int> fold_of(order.size());
  for (size_t i = 0; i < order.size(); ++i) fold_of[static_cast<size_t>(order[i])] = static_cast<int>(i) % folds;
  double sum = 0;
  int count = 0;
  for (int f = 0; f < folds; ++f) {
    std::vector<bool> active(setup.obs.size());
    std::vector<int> per_photo(static_cast<size_t>(setup.photos), 0);
    for (size_t i = 0; i < setup.obs.size(); ++i) {
      active[i] = inlier[i] && fold_of[static_cast<size_t>(setup.obs[i].feature)] != f;
      if (active[i]) ++per_photo[static_cast<size_t>(setup.obs[i].photo)];
    }
    State st = w.state;
    BuiltProblem b = Build(setup, w.kind, w.basis.get(), active, false, &st);
    Solve(setup, b, &st);
    const std::vector<Eigen::Vector2d> r = Residuals(setup, w.kind, w.basis.get(), st);
    for (size_t i = 0; i < setup.obs.size(); ++i) {
      const Obs& o = setup.obs[i];
      if (!inlier[i] || fold_of[static_cast<size_t>(o.feature)] != f) continue;
      if (per_photo[static_cast<size_t>(o.photo)] < 6 || !r[i].allFinite()) continue;
      sum += r[i].squaredNorm();
      ++count;
    }
  }
  return count > 0 ? std::sqrt(sum / count) : kNaN;
}

// The lens model misfit as a correlated error in the model choice (ModelFit::lens_field_rss_px2). A smooth field
// common to every photo is partly absorbed by a richer screen model's extra shape parameters, which then wins on
// BIC and held-out error under a white-noise likelihood and carries the field into its radius (issue 16's
// validity bench: richer models chosen in 22 of 96 realistic single-photo trials at 30 deg yaw, R 948-998 mm,
// 8 misses). With the field's coefficients as random effects of prior RMS s (T = tau^2 I, tau^2 = s^2 n /
// trace(B^T B) per coordinate), the generalized residual sum of a candidate, profiled over its parameters
// (linearized at its optimum, J^T r = 0) and the field, is
//   sigma^2 r^T Sigma^-1 r = r^T r - r^T B~ (B~^T B~ + (sigma^2 / tau^2) I)^-1 B~^T r,   B~ = (I - P_J) B
// (Woodbury; the field's part that the model cannot absorb, shrunk by the prior). A candidate's gain that a field
// of the measured RMS explains is then no evidence for it; a screen shape that differs between photos (the same
// screen point seen at different image positions) or is larger than the measured field still is. The log
// determinant of Sigma is the same for every candidate and drops out of the comparison.
// s is measured on the same projection: q = r^T P_B~ r has E[q] = sigma^2 rank(B~) + tau^2 trace(B~^T B~), so
// s^2 = (q - sigma^2 rank) trace(B^T B) / (n trace(B~^T B~)) per candidate (sd about sigma^2 sqrt(2 rank) in q:
// 0.01-0.02 px on a single photo of 279 features at sigma 0.1 px, far tighter than the neighbour statistic of the
// budget's row); the smallest over the converged candidates (the least inflated by screen-shape error), capped at
// FitOptions::max_lens_misfit_relative of the image width. A Gaussian prior on 2 x terms coefficients bounds
// their energy only weakly against thousands of residuals, so the part taken off the residual sum is capped at
// what a field of RMS s and the noise put in the span: sigma^2 rank + tau^2 trace(B~^T B~) + 3 sigma^2
// sqrt(2 rank). Smooth residuals beyond that (a flat model on a curved screen, a mirrored photo) stay in.
// Field directions the fit absorbs almost wholly (B~ v ~ 0) are left out: there B~ is the difference of nearly
// equal numbers, and the residual's own small component along the fit's Jacobian (the solver stops at a
// tolerance, J^T r is not exactly 0) divided by such an eigenvalue gave q of several px^2 from white noise (a
// cylinder on 279 features at 0.1 px: eigenvalues 2e-9..5e-6 against a largest of about 50). 1e-4 of the largest
// keeps every direction that holds a visible share of a field.
double Absorbed(const Eigen::VectorXd& eigenvalues) { return 1e-4 * std::max(eigenvalues.maxCoeff(), 1e-300); }

void AdjustForLensField(const FitOptions& o, int width_px, const std::vector<ModelWork>& work,
                        ScreenFitResult* result) {
  auto& c = result->candidates;
  const double sigma2 = DetectionSigma(o) * DetectionSigma(o);
  struct Spectrum {
    Eigen::VectorXd eigenvalues, coordinates;  // of B~^T B~, and B~^T r in its eigenvectors
    int rank = 0;
    double q = 0, trace = 0;
  };
  std::vector<std::optional<Spectrum>> spectra(c.size());
  double s2 = kInf;
  for (size_t i = 0; i < c.size() && i < work.size(); ++i) {
    const LensFieldProjection& p = work[i].lens_field;
    if (p.observations == 0 || !(p.basis_trace > 0)) continue;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(p.gram);
    if (eig.info() != Eigen::Success) continue;
    Spectrum sp;
    sp.eigenvalues = eig.eigenvalues();
    sp.coordinates = eig.eigenvectors().transpose() * p.projected;
    for (long k = 0; k < sp.eigenvalues.size(); ++k) {
      if (sp.eigenvalues[k] <= Absorbed(sp.eigenvalues)) continue;
      ++sp.rank;
      sp.q += sp.coordinates[k] * sp.coordinates[k] / sp.eigenvalues[k];
      sp.trace += sp.eigenvalues[k];
    }
    if (sp.rank == 0 || !std::isfinite(sp.q)) continue;
    if (c[i].converged) {
      s2 = std::min(s2, std::max(0.0, sp.q - sigma2 * sp.rank) * p.basis_trace / (p.observations * sp.trace));
    }
    spectra[i] = sp;
  }
  if (!std::isfinite(s2)) return;
  const double s = std::min(std::sqrt(s2), o.max_lens_misfit_relative * width_px);
  if (!(s > 0)) return;
  result->lens_field_px = s;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!spectra[i]) continue;
    const Spectrum& sp = *spectra[i];
    const LensFieldProjection& p = work[i].lens_field;
    const double tau2 = s * s * p.observations / p.basis_trace;
    double explained = 0;
    for (long k = 0; k < sp.eigenvalues.size(); ++k) {
      if (sp.eigenvalues[k] > Absorbed(sp.eigenvalues)) explained += sp.coordinates[k] * sp.coordinates[k] / (sp.eigenvalues[k] + sigma2 / tau2);
    }
    const double most = sigma2 * sp.rank + tau2 * sp.trace + 3 * sigma2 * std::sqrt(2.0 * sp.rank);
    explained = std::clamp(explained, 0.0, most);
    ModelFit& f = c[i];
    const int n = 2 * p.observations;
    const double rss = std::max(p.rss - explained, 0.0);
    f.lens_field_rss_px2 = explained;
    f.bic_white = f.bic;
    const double floor_rss = n * o.noise_floor_px * o.noise_floor_px;
    f.bic = n * std::log(std::max({rss, floor_rss, 1e-300}) / n) + f.parameters * std::log(static_cast<double>(n));
    if (std::isfinite(f.heldout_rms_px)) {
      f.heldout_adjusted_px =
          std::sqrt(std::max(0.0, f.heldout_rms_px * f.heldout_rms_px - explained / p.observations));
    }
    Adequacy(o, rss, n, &f, fmt::format(" after a lens model misfit of RMS {:.4f} px", s));
  }
}

// The simplest model whose BIC is within bic_margin of the lowest and whose held-out RMS is within
// heldout_tolerance of the lowest, among the adequate candidates (all, when none is adequate).
void Choose(const FitOptions& options, ScreenFitResult* result) {
  const auto& c = result->candidates;
  // Held-out RMS (of the 2D residual's length) floored at the detections' systematic error.
  const double held_floor = std::sqrt(2.0) * options.noise_floor_px;
  const auto held = [&](size_t i) {
    return std::max(std::isfinite(c[i].heldout_adjusted_px) ? c[i].heldout_adjusted_px : c[i].heldout_rms_px,
                    held_floor);
  };
  // The pool: converged and adequate candidates; every converged one when none is adequate (then the result is
  // inadequate whatever is chosen).
  std::string inadequate;
  bool any_adequate = false;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!c[i].converged) continue;
    if (c[i].adequate) any_adequate = true;
    else inadequate += (inadequate.empty() ? "" : ", ") + c[i].model;
  }
  const auto in_pool = [&](size_t i) { return c[i].converged && (c[i].adequate || !any_adequate); };
  const std::string pool_note =
      (inadequate.empty() ? std::string()
       : any_adequate     ? "; left out as inadequate: " + inadequate
                          : "; no candidate is adequate") +
      (result->lens_field_px > 0
           ? fmt::format("; residuals compared after a lens model misfit field of RMS {:.4f} px common to every "
                         "photo (a correlated error, not evidence for a shape)",
                         result->lens_field_px)
           : std::string());
  double best_bic = kInf, best_held = kInf;
  int best_bic_i = -1, best_held_i = -1;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!in_pool(i)) continue;
    if (c[i].bic < best_bic) best_bic = c[i].bic, best_bic_i = static_cast<int>(i);
    if (held(i) < best_held) best_held = held(i), best_held_i = static_cast<int>(i);
  }
  if (best_bic_i < 0) {
    // Nothing converged: take the lowest BIC anyway and say so.
    for (size_t i = 0; i < c.size(); ++i) {
      if (c[i].bic < best_bic) best_bic = c[i].bic, best_bic_i = static_cast<int>(i);
    }
    result->chosen = best_bic_i;
    result->choice_reason = "no model converged; the lowest BIC is shown";
    return;
  }
  const bool use_held = best_held_i >= 0;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!in_pool(i)) continue;
    const bool bic_ok = c[i].bic <= best_bic + options.bic_margin;
    const bool held_ok = !use_held || held(i) <= best_held * (1 + options.heldout_tolerance);
    if (bic_ok && held_ok) {
      result->chosen = static_cast<int>(i);
      const std::string name = c[i].model;
      if (!use_held) {
        result->choice_reason = fmt::format(
            "{}: the simplest model within {:g} of the lowest BIC ({}); held-out errors were not computed", name,
            options.bic_margin, c[static_cast<size_t>(best_bic_i)].model);
      } else if (static_cast<int>(i) == best_bic_i && static_cast<int>(i) == best_held_i) {
        result->choice_reason = fmt::format("BIC and held-out error both favour {}", name);
      } else {
        result->choice_reason = fmt::format(
            "{}: the simplest model within {:g} of the lowest BIC ({}) and within {:g}% of the lowest held-out "
            "error ({}, {:.4f} px)",
            name, options.bic_margin, c[static_cast<size_t>(best_bic_i)].model, 100 * options.heldout_tolerance,
            c[static_cast<size_t>(best_held_i)].model, best_held);
      }
      result->choice_reason += pool_note;
      return;
    }
  }
  result->chosen = best_bic_i;
  result->choice_reason = fmt::format(
      "BIC and held-out error disagree (lowest BIC: {}, lowest held-out error: {}); the lowest BIC is taken",
      c[static_cast<size_t>(best_bic_i)].model, c[static_cast<size_t>(best_held_i)].model) + pool_note;
}

void Deviations(const Setup& setup, const ModelWork& w, ScreenFitResult* result) {
  const FitOptions& opt = *setup.options;
  const ModelFit& fit = result->Chosen();
  const bool field = w.kind == ScreenModelKind::kCylinderDeviation;
  const auto field_at = [&](const Eigen::Vector2d& uv) {
    return field ? w.basis->Weights(uv).dot(Eigen::Map<const Eigen::VectorXd>(w.state.dev.data(),
                                                                                static_cast<long>(w.state.dev.size())))
                 : 0.0;
  };
  std::vector<int> index_in_photo(static_cast<size_t>(setup.photos), 0);
  for (const Obs& o : setup.obs) {
    FeatureDeviation d;
    d.photo = o.photo;
    d.id = setup.feature_ids[static_cast<size_t>(o.feature)];
    d.uv = o.uv;
    const Eigen::Vector2d r = fit.residual_px[static_cast<size_t>(o.photo)][static_cast<size_t>(o.index)];
    d.outlier = fit.outlier[static_cast<size_t>(o.photo)][static_cast<size_t>(o.index)];
    const std::vector<const double*> blocks = Blocks(w.state, o.photo);
    Eigen::Vector2d q, dq_dn;
    const bool ok = MakeCost(setup, w.kind, w.basis.get(), o)->PredictWithNormal(blocks.data(), &q, &dq_dn);
    const double g = ok ? dq_dn.norm() : 0;
    const double g_floor = std::max(g, 1e-6);
    d.normal_mm = field_at(o.uv) + (g > 1e-6 && r.allFinite() ? dq_dn.dot(r) / (g * g) : 0.0);
    d.sigma_mm = result->noise_px / g_floor;
    result->deviations.push_back(d);
  }
  // Map.
  result->map_nu = opt.map_nu;
  result->map_nv = opt.map_nv;
  result->map_mm.assign(static_cast<size_t>(opt.map_nu * opt.map_nv), kNaN);
  result->map_sigma_mm.assign(result->map_mm.size(), kNaN);
  for (int j = 0; j < opt.map_nv; ++j) {
    for (int i = 0; i < opt.map_nu; ++i) {
      const Eigen::Vector2d uv(-1 + (2 * i + 1.0) / opt.map_nu, -1 + (2 * j + 1.0) / opt.map_nv);
      const size_t cell = static_cast<size_t>(j * opt.map_nu + i);
      bool supported = false;
      double sw = 0, swd = 0;
      const double reach2 = std::max(16 * opt.map_smoothing_uv * opt.map_smoothing_uv,
                                     opt.map_support_uv * opt.map_support_uv);
      for (const FeatureDeviation& d : result->deviations) {
        if (d.outlier) continue;
        const double dist2 = (d.uv - uv).squaredNorm();
        if (dist2 > reach2) continue;  // beyond 4 kernel sigmas: weight below 3e-4
        if (dist2 <= opt.map_support_uv * opt.map_support_uv) supported = true;
        const double kern = std::exp(-0.5 * dist2 / (opt.map_smoothing_uv * opt.map_smoothing_uv));
        const double wt = kern / (d.sigma_mm * d.sigma_mm);
        sw += wt;
        swd += wt * d.normal_mm;
      }
      if (!supported) continue;
      if (field) {
        const Eigen::VectorXd wv = w.basis->Weights(uv);
        result->map_mm[cell] = field_at(uv);
        result->map_sigma_mm[cell] =
            w.dev_covariance.size() > 0 ? std::sqrt(std::max(0.0, wv.dot(w.dev_covariance * wv))) : kNaN;
      } else if (sw > 0) {
        const double sigma = 1 / std::sqrt(sw);
        if (sigma > opt.map_max_sigma_mm) continue;
        result->map_mm[cell] = swd / sw;
        result->map_sigma_mm[cell] = sigma;
      }
    }
  }
}

// The warning for an inadequate chosen model: its figures, per photo when there are several (a wrong pattern.json
// shows in one photo), and the likely causes.
std::string InadequacyWarning(const std::vector<PhotoObservations>& photos, const ScreenFitResult& result) {
  const ModelFit& m = result.Chosen();
  std::string s = fmt::format(
      "{}: inadequate: the fit's residual noise is {:.3f} px per coordinate (RMS {:.3f} px), {:.1f} times the {} "
      "detection noise of {:.3f} px (limit {:.3f} px); chi2/dof = {:.4g}/{} = {:.3g}, p = {:.2g}.",
      m.model, m.noise_px, m.rms_px, m.noise_ratio,
      result.detection_noise_assumed ? "assumed (not measured: --expected-noise)" : "measured",
      result.detection_noise_px, result.adequacy_limit_px, m.chi2, m.dof, m.dof > 0 ? m.chi2 / m.dof : kNaN,
      m.chi2_p_value);
  std::string others;
  for (const ModelFit& c : result.candidates) {
    if (&c == &m) continue;
    others += fmt::format("{}{} {:.3f} px", others.empty() ? "" : ", ", c.model, c.noise_px);
  }
  s += others.empty() ? " It was the only model tried." : " No candidate fits better than that (" + others + ").";
  if (m.residual_px.size() > 1) {
    // Per-photo RMS of the inliers: the worst photo and the median of the others.
    std::vector<std::pair<double, size_t>> rms;
    for (size_t p = 0; p < m.residual_px.size(); ++p) {
      double sum = 0;
      int count = 0;
      for (size_t i = 0; i < m.residual_px[p].size(); ++i) {
        if (m.outlier[p][i] || !m.residual_px[p][i].allFinite()) continue;
        sum += m.residual_px[p][i].squaredNorm();
        ++count;
      }
      rms.emplace_back(count > 0 ? std::sqrt(sum / count) : kNaN, p);
    }
    std::sort(rms.begin(), rms.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<double> rest;
    for (size_t i = 1; i < rms.size(); ++i) rest.push_back(rms[i].first);
    const std::string& name = photos[rms[0].second].photo;
    s += fmt::format(" Worst photo: {} with an RMS of {:.3f} px (median of the other {}: {:.3f} px).",
                     name.empty() ? fmt::format("photo {}", rms[0].second + 1) : name, rms[0].first, rest.size(),
                     Median(rest));
  }
  s += " Its parameters are not measurements. Likely causes: the wrong pattern.json for a photo (e.g. two "
       "--pattern files in the wrong order), the wrong camera model (another camera's or another focus's "
       "calibration), a mirrored photo, or a screen that no model in the list fits (e.g. --models flat on a curved "
       "monitor).";
  return s;
}

// The chosen model's curvature against the nominal: a radius beyond both 5 sigma and 25% of the nominal, a flat
// screen measured on a monitor specified curved, or a curved one on a monitor specified flat.
std::optional<std::string> PlausibilityWarning(const Monitor& nominal, const ScreenFitResult& result) {
  const ModelFit& m = result.Chosen();
  const double kn = nominal.curvature_per_mm;
  if (m.radius_mm) {
    const double r = *m.radius_mm, sr = m.radius_sigma_mm.value_or(kNaN);
    if (kn == 0) {
      return fmt::format(
          "{}: implausible: the screen measures curved, R = {:.0f} +- {:.0f} mm (95% interval {:.0f} to {:.0f} mm), "
          "but the monitor is specified flat; check the monitor given, and the camera model (a wrong lens model "
          "bends straight lines).",
          m.model, r, sr, m.radius_ci95_mm[0], m.radius_ci95_mm[1]);
    }
    const double rn = 1 / kn, d = r - rn;
    if (std::abs(d) > 5 * sr && std::abs(d) > 0.25 * std::abs(rn)) {
      return fmt::format(
          "{}: implausible: the radius {:.0f} +- {:.0f} mm is {:+.0f} mm ({:+.0f}%, {:.0f} sigma) from the nominal "
          "{:.0f} mm; check the monitor given (its radius and pixel pitch: the scale of the fit is the pitch's), "
          "the camera model and the pattern.json.",
          m.model, r, sr, d, 100 * d / std::abs(rn), std::abs(d) / sr, rn);
    }
    return std::nullopt;
  }
  if (kn == 0) return std::nullopt;
  // No radius: the flat model, or a curved model whose 95% interval holds flat. The evidence about the curvature
  // is the chosen model's own, or the cylinder's when flat was chosen. An ill-conditioned one says that the
  // photos cannot tell (its own warning); none fitted: only flat was tried.
  const ModelFit* evidence = &m;
  if (m.model == "flat") {
    evidence = nullptr;
    for (const ModelFit& c : result.candidates) {
      if (c.model == "cylinder") evidence = &c;
    }
    if (!evidence) {
      return fmt::format(
          "flat: implausible: a flat screen was fitted to a monitor specified {:.0f}R and no curved model was tried "
          "(check --models); the curvature was not measured.",
          1 / kn);
    }
  }
  if (evidence->ill_conditioned || !evidence->converged) return std::nullopt;
  const double k = evidence->curvature_per_mm, sk = evidence->curvature_sigma_per_mm;
  const bool far = std::abs(k - kn) > 5 * sk && (k * kn <= 0 || std::abs(1 / k - 1 / kn) > 0.25 * std::abs(1 / kn));
  if (!far) return std::nullopt;
  return fmt::format(
      "{}: implausible: the screen measures flat on a monitor specified {:.0f}R: the {} curvature is {:.3g} +- {:.3g} "
      "/m (R beyond {:.0f} mm at 95%), {:.0f} sigma from the nominal {:.3g} /m; check the monitor given, and the "
      "pattern.json and camera model.",
      m.model, 1 / kn, evidence->model, 1000 * k, 1000 * sk, evidence->radius_lower_bound_mm,
      sk > 0 ? std::abs(k - kn) / sk : kInf, 1000 * kn);
}

void CheckPhotos(const std::vector<PhotoObservations>& photos, const FitOptions& options) {
  if (photos.empty()) throw Error("fit", "no photos to fit", "give at least one photo with detected features");
  for (const PhotoObservations& p : photos) {
    const std::string where = p.photo.empty() ? "fit" : p.photo;
    if (p.ids.size() != p.display_px.size() || p.ids.size() != p.detected_px.size()) {
      throw Error(where,
                  fmt::format("{} ids, {} display positions and {} detections do not match", p.ids.size(),
                              p.display_px.size(), p.detected_px.size()),
                  "give one display position and one detection per feature id");
    }
    if (static_cast<int>(p.ids.size()) < options.min_features_per_photo) {
      throw Error(where, fmt::format("only {} features", p.ids.size()),
                  fmt::format("a photo needs at least {} detected features", options.min_features_per_photo));
    }
    std::set<std::string> seen;
    for (size_t i = 0; i < p.ids.size(); ++i) {
      if (!p.display_px[i].allFinite() || !p.detected_px[i].allFinite()) {
        throw Error(where, fmt::format("feature '{}' has a position that is not finite", p.ids[i]),
                    "drop features that were not detected");
      }
      if (!seen.insert(p.ids[i]).second) {
        throw Error(where, fmt::format("feature '{}' appears twice", p.ids[i]), "give each feature once per photo");
      }
    }
  }
}

}  // namespace

void FitOptions::Check(const std::string& where) const {
  if (models.empty()) throw Error(where, "no screen models to try", "give at least one, e.g. cylinder");
  const auto positive = [&](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) {
      throw Error(where, fmt::format("{} is {}, but must be a positive number", name, v), "");
    }
  };
  // Named as the user sets it (analyze --expected-noise), not by this field's name.
  if (!(expected_noise_px > 0) || !std::isfinite(expected_noise_px)) {
    throw Error("--expected-noise", fmt::format("{} px is not a detection noise level", expected_noise_px),
                "give the expected detection noise per coordinate in px, a positive number such as 0.15");
  }
  if (!(detection_noise_px >= 0) || !std::isfinite(detection_noise_px)) {
    throw Error(where, fmt::format("detection_noise_px is {}, but must be 0 (unknown) or a positive number",
                                   detection_noise_px),
                "");
  }
  if (!(adequacy_p_value > 0 && adequacy_p_value < 1)) {
    throw Error(where, fmt::format("adequacy_p_value is {}, but must be between 0 and 1", adequacy_p_value),
                "give e.g. 0.001");
  }
  if (!(adequacy_noise_ratio >= 1) || !std::isfinite(adequacy_noise_ratio)) {
    throw Error(where, fmt::format("adequacy_noise_ratio is {}, but must be 1 or more", adequacy_noise_ratio),
                "give e.g. 1.5");
  }
  if (!(smooth_bias_px >= 0) || !std::isfinite(smooth_bias_px)) {
    throw Error(where, fmt::format("smooth_bias_px is {}, but must be 0 or a positive number", smooth_bias_px), "");
  }
  if (!(noise_floor_px >= 0) || !std::isfinite(noise_floor_px)) {
    throw Error(where, fmt::format("noise_floor_px is {}, but must be 0 or a positive number", noise_floor_px), "");
  }
  positive(huber_sigmas, "huber_sigmas");
  positive(outlier_sigmas, "outlier_sigmas");
  positive(deviation_prior_mm, "deviation_prior_mm");
  positive(map_smoothing_uv, "map_smoothing_uv");
  positive(map_support_uv, "map_support_uv");
  positive(map_max_sigma_mm, "map_max_sigma_mm");
  if (!(outlier_min_px >= 0)) throw Error(where, "outlier_min_px is negative", "give 0 or more");
  if (!(bic_margin >= 0)) throw Error(where, "bic_margin is negative", "give 0 or more (10: very strong)");
  if (!(heldout_tolerance >= 0)) throw Error(where, "heldout_tolerance is negative", "give e.g. 0.05");
  if (heldout_folds < 0 || heldout_folds == 1) {
    throw Error(where, fmt::format("heldout_folds is {}", heldout_folds), "give 0 (off) or 2 or more");
  }
  if (deviation_nu < 4 || deviation_nv < 4) {
    throw Error(where, "the deviation field needs at least 4 x 4 coefficients", "raise deviation_nu/nv");
  }
  if (map_nu < 1 || map_nv < 1) throw Error(where, "the deviation map needs at least 1 x 1 cells", "");
  if (max_iterations < 1) throw Error(where, "max_iterations must be at least 1", "");
  if (min_features_per_photo < 6) throw Error(where, "min_features_per_photo below 6 leaves the pose free", "");
  positive(max_relative_curvature_sigma, "max_relative_curvature_sigma");
  if (!(pitch_tolerance_relative >= 0 && pitch_tolerance_relative < 0.5)) {
    throw Error(where, fmt::format("the pixel-pitch tolerance is {}, but must be a fraction in [0, 0.5)",
                                   pitch_tolerance_relative),
                "give e.g. 0.001 for 0.1%");
  }
  if (systematic_field_degree < 0 || systematic_field_degree > 8) {
    throw Error(where, fmt::format("systematic_field_degree is {}", systematic_field_degree), "give 0 to 8 (3)");
  }
  if (misfit_field_degree < 1 || misfit_field_degree > 12) {
    throw Error(where, fmt::format("misfit_field_degree is {}", misfit_field_degree), "give 1 to 12 (6)");
  }
  if (systematic_field_draws < 10) throw Error(where, "systematic_field_draws below 10", "give e.g. 2000");
  if (!(coverage_probability > 0 && coverage_probability < 1)) {
    throw Error(where, fmt::format("coverage_probability is {}", coverage_probability), "give e.g. 0.95");
  }
  if (intrinsics_covariance.rows() != intrinsics_covariance.cols() || !intrinsics_covariance.allFinite()) {
    throw Error(where, "the intrinsics covariance is not a finite square matrix", "");
  }
}

ScreenFitResult FitScreen(const Monitor& nominal, const CameraModel& camera,
                          const std::vector<PhotoObservations>& photos, const FitOptions& options) {
  nominal.Check("nominal monitor");
  camera.Check("camera model");
  options.Check("fit options");
  if (options.intrinsics_covariance.size() > 0 &&
      options.intrinsics_covariance.rows() != static_cast<long>(camera.intrinsics.size())) {
    throw Error(options.intrinsics_covariance_source.empty() ? "fit options" : options.intrinsics_covariance_source,
                fmt::format("the intrinsics covariance is {} x {}, but the camera model has {} intrinsics",
                            options.intrinsics_covariance.rows(), options.intrinsics_covariance.cols(),
                            camera.intrinsics.size()),
                "give the covariance written with this camera model");
  }
  CheckPhotos(photos, options);

  Setup setup;
  setup.nominal = &nominal;
  setup.camera = &camera;
  setup.projector.emplace(camera);
  setup.options = &options;
  setup.photos = static_cast<int>(photos.size());
  setup.half_width_mm = 0.5 * nominal.width_mm;
  std::unordered_map<std::string, int> feature_index;
  for (size_t p = 0; p < photos.size(); ++p) {
    for (size_t i = 0; i < photos[p].ids.size(); ++i) {
      Obs o;
      o.photo = static_cast<int>(p);
      o.index = static_cast<int>(i);
      auto [it, inserted] = feature_index.emplace(photos[p].ids[i], static_cast<int>(setup.feature_ids.size()));
      if (inserted) setup.feature_ids.push_back(photos[p].ids[i]);
      o.feature = it->second;
      o.uv = UvFromDisplayPx(nominal, photos[p].display_px[i]);
      o.s_mm = 0.5 * o.uv.x() * nominal.width_mm;
      o.y_mm = -0.5 * o.uv.y() * nominal.height_mm;
      o.detected = photos[p].detected_px[i];
      setup.obs.push_back(o);
    }
  }

  std::vector<ScreenModelKind> kinds;
  for (ScreenModelKind k : AllScreenModels()) {
    if (std::find(options.models.begin(), options.models.end(), k) != options.models.end()) {
      kinds.push_back(k);
    }
  }

  // Initial poses from PnP against the nominal surface.
  State initial;
  for (int p = 0; p < setup.photos; ++p) initial.poses.push_back(InitialPose(setup, p));

  // Pass 1: robust fits, in order of complexity; richer models start from the cylinder's solution.
  std::vector<ModelWork> work;
  std::vector<double> time_ms;
  const std::vector<bool> all(setup.obs.size(), true);
  work.reserve(kinds.size());
  int cylinder = -1;  // index into work
  ScreenFitResult result;
  for (ScreenModelKind kind : kinds) {
    // A model needs at least 3 residuals per parameter (shape and poses) to be worth fitting and comparing.
    const int shape_parameters =
        CoreParameterCount(kind) +
        (kind == ScreenModelKind::kCylinderDeviation ? options.deviation_nu * options.deviation_nv - 5 : 0);
    const int parameters =
        shape_parameters + 6 * setup.photos + (options.fit_intrinsics ? static_cast<int>(camera.intrinsics.size()) : 0);
    if (2 * static_cast<int>(setup.obs.size()) < 3 * parameters) {
      result.skipped.push_back(fmt::format(
          "{} not tried: {} observations give {} residuals, fewer than 3 per parameter ({} parameters); use a "
          "denser pattern or more photos",
          ScreenModelName(kind), setup.obs.size(), 2 * setup.obs.size(), parameters));
      continue;
    }
    const Stopwatch watch;
    ModelWork w;
    w.kind = kind;
    const State* from = cylinder >= 0 ? &work[static_cast<size_t>(cylinder)].state : nullptr;
    w.state.poses = from ? from->poses : initial.poses;
    if (options.fit_intrinsics) w.state.intr = from ? from->intr : camera.intrinsics;
    const double k0 = from ? from->core[0] : nominal.curvature_per_mm;
    w.state.core.assign(static_cast<size_t>(CoreParameterCount(kind)), 0.0);
    if (!w.state.core.empty()) w.state.core[0] = k0;
    if (kind == ScreenModelKind::kCylinderDeviation) {
      w.basis = std::make_unique<DeviationBasis>(nominal, k0, options.deviation_nu, options.deviation_nv);
      w.basis_curvature_per_mm = k0;
      w.state.dev.assign(static_cast<size_t>(w.basis->size()), 0.0);
    }
    FitRobust(setup, w, all);
    time_ms.push_back(watch.Ms());
    work.push_back(std::move(w));
    if (kind == ScreenModelKind::kCylinder && work.back().robust_ok) cylinder = static_cast<int>(work.size()) - 1;
  }

  // Common outliers: observations that even the best-fitting model (lowest robust noise) does not explain.
  int best = -1;
  double best_sigma = kInf;
  for (size_t i = 0; i < work.size(); ++i) {
    const double s = MadSigma(work[i].robust_residuals);
    if (work[i].robust_ok && s < best_sigma) best_sigma = s, best = static_cast<int>(i);
  }
  std::vector<bool> inlier(setup.obs.size(), true);
  if (best >= 0) {
    const double threshold = std::max(options.outlier_sigmas * best_sigma, options.outlier_min_px);
    const auto& r = work[static_cast<size_t>(best)].robust_residuals;
    for (size_t i = 0; i < r.size(); ++i) inlier[i] = r[i].allFinite() && r[i].norm() <= threshold;
  }

  for (size_t i = 0; i < work.size(); ++i) {
    const Stopwatch watch;
    ModelFit fit;
    fit.model = ScreenModelName(work[i].kind);
    FitFinal(setup, work[i], inlier, &fit);
    fit.heldout_rms_px = HeldOut(setup, work[i], inlier);
    fit.time_ms = time_ms[i] + watch.Ms();
    result.candidates.push_back(std::move(fit));
  }
  result.detection_noise_px = DetectionSigma(options);
  result.detection_noise_assumed = !(options.detection_noise_px > 0);
  result.adequacy_limit_px = AdequacyLimit(options);
  AdjustForLensField(options, camera.width, work, &result);
  Choose(options, &result);
  result.noise_px = result.Chosen().noise_px;
  if (!result.Chosen().adequate) {
    result.status = "inadequate";
    result.warnings.push_back(InadequacyWarning(photos, result));
  }
  for (size_t i = 0; i < result.candidates.size(); ++i) {
    const ModelFit& c = result.candidates[i];
    if (!c.ill_conditioned) continue;
    std::string note = c.condition_note;
    while (!note.empty() && note.back() == ' ') note.pop_back();
    result.warnings.push_back(c.model + ": ill-conditioned: " + note);
    if ((static_cast<int>(i) == result.chosen || c.model == "cylinder") && result.status == "ok") {
      result.status = "ill_conditioned";
    }
  }
  if (std::optional<std::string> w = PlausibilityWarning(nominal, result)) result.warnings.push_back(*w);
  Deviations(setup, work[static_cast<size_t>(result.chosen)], &result);

  result.assumptions.push_back(fmt::format(
      "pixel pitch fixed from the spec: {} x {} px over {:.2f} x {:.2f} mm ({:.4f} mm/px); scale is not observable "
      "from photos, so radius and distances scale with it",
      nominal.width_px, nominal.height_px, nominal.width_mm, nominal.height_mm, nominal.pixel_pitch_mm()));
  result.assumptions.push_back(
      options.fit_intrinsics
          ? fmt::format("lens intrinsics ({}) estimated jointly with the poses and the screen, seeded from the given "
                        "model; their uncertainty is in the joint covariance",
                        camera.lensmodel)
      : options.intrinsics_covariance.size() > 0
          ? fmt::format("lens model fixed in the fit: {} as calibrated; its calibration covariance ({}) is propagated "
                        "into the sigmas (uncertainty budget, lens calibration row)",
                        camera.lensmodel, options.intrinsics_covariance_source)
          : fmt::format("lens model fixed: {} as calibrated; {}", camera.lensmodel, options.lens_exact_note));
  result.assumptions.push_back(fmt::format(
      "sigmas and intervals are the combined standard uncertainty of the budget (detection noise, detector "
      "systematic, lens calibration, pixel pitch); the 95% interval uses Student's t at the effective degrees of "
      "freedom (Welch-Satterthwaite)"));
  result.assumptions.push_back(
      "detection noise isotropic and Gaussian; sigmas scaled by the measured residual noise (reduced chi-square)");
  result.assumptions.push_back(
      result.detection_noise_assumed
          ? fmt::format("detection noise not measured: each model's fit was tested against an assumed {:.3f} px per "
                        "coordinate (--expected-noise); adequacy is only as good as that guess",
                        result.detection_noise_px)
          : fmt::format("each model's fit tested against the measured detection noise, {:.3f} px per coordinate",
                        result.detection_noise_px));
  result.assumptions.push_back(
      "deviations are along the surface normal; displacements within the surface are not modelled");
  if (std::find(kinds.begin(), kinds.end(), ScreenModelKind::kCylinderDeviation) != kinds.end()) {
    result.assumptions.push_back(fmt::format(
        "deviation field: {} x {} cubic B-splines with the rigid and radius modes removed (zero mean, no tilt, no "
        "curvature relative to the fitted cylinder) and a {:g} mm prior",
        options.deviation_nu, options.deviation_nv, options.deviation_prior_mm));
  }
  return result;
}

void ChooseModel(const FitOptions& options, ScreenFitResult* result) { Choose(options, result); }

double ChiSquareUpperTail(double chi2, double dof) {
  if (!(dof > 0) || !(chi2 >= 0)) return kNaN;
  if (chi2 == 0) return 1;
  if (std::isinf(chi2)) return 0;
  // Q(a, x) = Gamma(a, x) / Gamma(a), a = dof/2, x = chi2/2 (Numerical Recipes 6.2): below x = a + 1 the series
  // of P = 1 - Q (Q > 0.08 there for every a, so 1 - P loses at most a digit); above, Q's continued fraction
  // (modified Lentz), accurate far into the tail. Both converge in O(sqrt(a)) terms.
  const double a = 0.5 * dof, x = 0.5 * chi2;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  constexpr int kMaxTerms = 10000000;
  constexpr double kEps = 1e-16, kTiny = 1e-300;
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < kMaxTerms; ++n) {
      term *= x / (a + n);
      sum += term;
      if (term < sum * kEps) break;
    }
    return std::clamp(1 - sum * std::exp(log_prefix), 0.0, 1.0);
  }
  double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
  for (int i = 1; i < kMaxTerms; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < kEps) break;
  }
  return std::clamp(std::exp(log_prefix) * h, 0.0, 1.0);
}

double RadiusCramerRaoBoundMm(const Monitor& true_monitor, const CameraModel& camera,
                              const std::vector<Pose>& centre_from_cams,
                              const std::vector<std::vector<Eigen::Vector2d>>& display_px, double sigma_px) {
  true_monitor.Check("true monitor");
  camera.Check("camera model");
  if (true_monitor.is_flat()) {
    throw Error("Cramer-Rao bound", "the true monitor is flat: the radius is infinite", "give a curved monitor");
  }
  if (centre_from_cams.size() != display_px.size() || centre_from_cams.empty()) {
    throw Error("Cramer-Rao bound", "give one pose per list of display positions", "");
  }
  State st;
  st.core = {true_monitor.curvature_per_mm};
  for (const Pose& p : centre_from_cams) {
    const Eigen::Quaterniond& q = p.rotation;
    st.poses.push_back({q.x(), q.y(), q.z(), q.w(), p.translation.x(), p.translation.y(), p.translation.z()});
  }
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> manifold{
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<3>()};
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem pr(po);
  for (size_t p = 0; p < centre_from_cams.size(); ++p) {
    for (const Eigen::Vector2d& px : display_px[p]) {
      const Eigen::Vector2d uv = UvFromDisplayPx(true_monitor, px);
      const double s = 0.5 * uv.x() * true_monitor.width_mm, y = -0.5 * uv.y() * true_monitor.height_mm;
      // The detection is the noiseless prediction: the Jacobian does not depend on it.
      pr.AddResidualBlock(new ReprojectionCost(&camera, ScreenModelKind::kCylinder, s, y, 0.5 * true_monitor.width_mm,
                                               Eigen::Vector2d::Zero()),
                          nullptr, {st.poses[p].data(), st.core.data()});
    }
    pr.SetManifold(st.poses[p].data(), &manifold);
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  const std::vector<std::pair<const double*, const double*>> pairs = {{st.core.data(), st.core.data()}};
  if (!cov.Compute(pairs, &pr)) {
    throw Error("Cramer-Rao bound", "the radius is not observable in this configuration (singular Fisher matrix)",
                "add features or photos from other positions");
  }
  double ckk = 0;
  cov.GetCovarianceBlock(st.core.data(), st.core.data(), &ckk);
  const double k = true_monitor.curvature_per_mm;
  return sigma_px * std::sqrt(ckk) / (k * k);
}

}  // namespace curvecheck
