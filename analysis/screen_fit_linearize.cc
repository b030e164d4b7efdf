// The screen fit's linearization at its final solution (analysis/screen_fit_internal.h): the dense Jacobian in the
// parameters' tangent space, the equilibrated pseudo-inverse of the normal matrix and G, through which the
// uncertainty budget (screen_fit_budget.cc) propagates each source; J y and J^T x run by run.
#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"

namespace curvecheck::screen_fit_internal {

// The final fit's Jacobian at the solution, dense, in the parameters' tangent space (every residual block: the
// active observations, then the deviation prior), its equilibrated pseudo-inverse (J^T J)^+ (the covariance's
// unscaled form: Covariances reads its blocks) and G = sel (J^T J)^+ J^T for the budget's rows.
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
  const int dev_offset = t;
  if (!st.dev.empty()) eo.parameter_blocks.push_back(st.dev.data()), t += static_cast<int>(st.dev.size());
  const int intr_offset = t;
  if (!st.intr.empty()) eo.parameter_blocks.push_back(st.intr.data()), t += static_cast<int>(st.intr.size());
  ceres::CRSMatrix crs;
  std::vector<double> gradient;
  if (!b.problem->Evaluate(eo, nullptr, nullptr, &gradient, &crs)) {
    *note += "the Jacobian could not be evaluated; ";
    return std::nullopt;
  }
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int i = crs.rows[static_cast<size_t>(r)]; i < crs.rows[static_cast<size_t>(r) + 1]; ++i) {
      j(r, crs.cols[static_cast<size_t>(i)]) = crs.values[static_cast<size_t>(i)];
    }
  }
  Linearization lin;
  const size_t n_obs = b.obs_index.size();
  lin.j_obs = j.topRows(static_cast<long>(2 * n_obs));
  lin.shared_col = core_offset;  // the poses' columns come first
  for (size_t i = 0; i < n_obs; ++i) {
    const long pose_col = pose_offset[static_cast<size_t>(setup.obs[b.obs_index[i]].photo)];
    if (lin.runs.empty() || lin.runs.back().pose_col != pose_col) {
      lin.runs.push_back({2 * static_cast<long>(i), 0, pose_col});
    }
    lin.runs.back().rows += 2;
  }
  // J^T J run by run (each run's dense block: its pose's 6 columns and the shared ones), then the rows past the
  // observations (the deviation prior).
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(t, t);
  {
    const long shared = t - lin.shared_col;
    Eigen::MatrixXd block;
    for (const Linearization::Run& run : lin.runs) {
      block.resize(run.rows, 6 + shared);
      block << lin.j_obs.block(run.row, run.pose_col, run.rows, 6),
          lin.j_obs.block(run.row, lin.shared_col, run.rows, shared);
      const Eigen::MatrixXd gram = block.transpose() * block;
      normal.block(run.pose_col, run.pose_col, 6, 6) += gram.topLeftCorner(6, 6);
      normal.block(run.pose_col, lin.shared_col, 6, shared) += gram.topRightCorner(6, shared);
      normal.block(lin.shared_col, run.pose_col, shared, 6) += gram.bottomLeftCorner(shared, 6);
      normal.bottomRightCorner(shared, shared) += gram.bottomRightCorner(shared, shared);
    }
    const long prior = j.rows() - lin.j_obs.rows();
    if (prior > 0) normal.noalias() += j.bottomRows(prior).transpose() * j.bottomRows(prior);
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
  // G = sel (J^T J)^+ J^T through the small normal matrix (t x t; J has thousands of rows). The parameters'
  // units differ by many orders (radians, mm, 1/mm: a column of the curvature is ~1e6 times a position's), so
  // the pseudo-inverse is taken of the column-equilibrated normal matrix, (J^T J)^+ = D (D J^T J D)^+ D with D =
  // diag(1 / |J_c|), dropping directions below 1e-12 of its largest eigenvalue (as the covariance's fallback
  // does). Without the scaling that cut dropped real, well-determined directions: at 3 m on axis the camera's
  // lateral position (nearly traded against its yaw) got no share of any correlated error.
  Eigen::VectorXd scale = j.colwise().norm().transpose();
  for (long c = 0; c < scale.size(); ++c) scale[c] = scale[c] > 0 ? 1 / scale[c] : 0;
  const Eigen::MatrixXd normal_scaled = scale.asDiagonal() * normal * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(normal_scaled);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double cut = 1e-12 * std::max(ev.maxCoeff(), 1e-300);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(ev.size());
  for (long i = 0; i < ev.size(); ++i) inv[i] = ev[i] > cut ? 1 / ev[i] : 0;
  const Eigen::MatrixXd vs = scale.asDiagonal() * eig.eigenvectors();
  const Eigen::MatrixXd x = vs * inv.asDiagonal() * (vs.transpose() * sel.transpose());
  lin.g = JTimes(lin, x).transpose();
  lin.sel_pinv = x.transpose();
  lin.obs = b.obs_index;
  lin.normal_pinv = vs * inv.asDiagonal() * vs.transpose();
  lin.normal = normal;
  lin.gradient = Eigen::Map<const Eigen::VectorXd>(gradient.data(), static_cast<long>(gradient.size()));
  lin.pose_offset = pose_offset;
  lin.core_offset = st.core.empty() ? -1 : core_offset;
  lin.dev_offset = st.dev.empty() ? -1 : dev_offset;
  lin.intr_offset = st.intr.empty() ? -1 : intr_offset;
  lin.dropped_directions = static_cast<int>((ev.array() <= cut).count());
  return lin;
}

Eigen::MatrixXd JTimes(const Linearization& lin, const Eigen::MatrixXd& y) {
  Eigen::MatrixXd out(lin.j_obs.rows(), y.cols());
  const long shared = lin.j_obs.cols() - lin.shared_col;
  for (const Linearization::Run& run : lin.runs) {
    auto rows = out.middleRows(run.row, run.rows);
    rows.noalias() = lin.j_obs.block(run.row, run.pose_col, run.rows, 6) * y.middleRows(run.pose_col, 6);
    rows.noalias() += lin.j_obs.block(run.row, lin.shared_col, run.rows, shared) * y.bottomRows(shared);
  }
  return out;
}

Eigen::MatrixXd JtTimes(const Linearization& lin, const Eigen::MatrixXd& x) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(lin.j_obs.cols(), x.cols());
  const long shared = lin.j_obs.cols() - lin.shared_col;
  for (const Linearization::Run& run : lin.runs) {
    const auto rows = x.middleRows(run.row, run.rows);
    out.middleRows(run.pose_col, 6).noalias() += lin.j_obs.block(run.row, run.pose_col, run.rows, 6).transpose() * rows;
    out.bottomRows(shared).noalias() += lin.j_obs.block(run.row, lin.shared_col, run.rows, shared).transpose() * rows;
  }
  return out;
}
}  // namespace curvecheck::screen_fit_internal
