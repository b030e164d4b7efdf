// The intrinsics' uncertainty budget of a calibration from the screen (from_screen.h FromScreenIntrinsicsBudget):
// the screen fit's own budget rows (analysis/screen_fit_budget.cc: detector systematic, lens model misfit), which it
// propagates to the curvature and the camera positions only, propagated here to the intrinsics through the same
// linearized refit. The screen fit corrects the curvature and the camera positions for its fitted pixel-locking
// signature; the intrinsics are not corrected, so here the signature stays an uncertainty (its bound, unknown phase).
//
// The linearization is rebuilt from the fit's public result, not from its Ceres problem: the residual of
// observation i of photo p is r_i = d_i - P(theta, T_p X_i), X_i the fitted surface point (FittedSurfacePointsInCamera,
// which places it by the photo's fitted pose), P the lens projection (libmrcal, exact dq/dp and dq/dintrinsics).
// Parameters: per photo a small rotation w and translation t of the camera frame (X -> X + w x X + t: the
// tangent space of the fit's pose block, in another basis, which does not change any covariance of the
// intrinsics), the screen's shape parameters (central differences of FittedSurfacePointsInCamera) and the
// intrinsics. J = dP/dparameters over the inliers; a detection error delta moves the solution by
// (J^T J)^+ J^T delta, so the intrinsics move by A delta, A the intrinsics rows of (J^T J)^+ J^T (pseudo-inverse
// of the column-equilibrated normal matrix, directions below 1e-12 of its largest eigenvalue dropped, as the
// budget's Linearize does). Checks: the rebuilt residuals equal the fit's (residual_check_px), and noise_px^2
// times the intrinsics block of (J^T J)^+ equals the fit's own covariance (noise_check).
#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "calibrate/from_screen.h"
#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 6.283185307179586;

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

}  // namespace

FromScreenIntrinsicsBudget IntrinsicsBudgetFromScreen(const std::vector<PhotoObservations>& photos,
                                                      const Monitor& monitor, const CameraModel& model,
                                                      const ModelFit& m, const FitOptions& options) {
  FromScreenIntrinsicsBudget out;
  const long ni = static_cast<long>(model.intrinsics.size());
  const int np = static_cast<int>(photos.size());
  if (static_cast<int>(m.cameras.size()) != np || static_cast<int>(m.residual_px.size()) != np ||
      m.intrinsics.size() != model.intrinsics.size() || m.intrinsics_covariance.rows() != ni || ni == 0) {
    out.note = "the fit has no intrinsics covariance or does not match the photos";
    return out;
  }
  const long ns = static_cast<long>(m.shape.size());
  const long cols = 6L * np + ns + ni;
  // The inliers: image position, Jacobian rows.
  std::vector<Eigen::Vector2d> detected;
  std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> rows;
  double worst_residual_diff = 0;
  for (int p = 0; p < np; ++p) {
    const PhotoObservations& ph = photos[static_cast<size_t>(p)];
    std::vector<size_t> use;
    std::vector<Eigen::Vector2d> uv;
    for (size_t i = 0; i < ph.detected_px.size(); ++i) {
      const bool outlier = i < m.outlier[static_cast<size_t>(p)].size() && m.outlier[static_cast<size_t>(p)][i];
      if (outlier || i >= m.residual_px[static_cast<size_t>(p)].size() ||
          !m.residual_px[static_cast<size_t>(p)][i].allFinite()) {
        continue;
      }
      use.push_back(i);
      uv.push_back(UvFromDisplayPx(monitor, ph.display_px[i]));
    }
    if (use.empty()) continue;
    const std::vector<Eigen::Vector3d> x = FittedSurfacePointsInCamera(monitor, m, p, uv, options);
    std::vector<Eigen::Matrix<double, 2, 3>> dq_dp;
    std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> dq_di;
    const std::vector<Eigen::Vector2d> q = ProjectPoints(model, x, &dq_dp, &dq_di);
    // Shape columns: central differences of the surface points.
    std::vector<std::vector<Eigen::Vector3d>> dx_ds;
    for (long k = 0; k < ns; ++k) {
      ModelFit plus = m, minus = m;
      const double h = 1e-6 * std::max(std::abs(m.shape[static_cast<size_t>(k)]), 1e-3);
      plus.shape[static_cast<size_t>(k)] += h;
      minus.shape[static_cast<size_t>(k)] -= h;
      const std::vector<Eigen::Vector3d> xp = FittedSurfacePointsInCamera(monitor, plus, p, uv, options);
      const std::vector<Eigen::Vector3d> xm = FittedSurfacePointsInCamera(monitor, minus, p, uv, options);
      std::vector<Eigen::Vector3d> d;
      for (size_t i = 0; i < x.size(); ++i) d.push_back((xp[i] - xm[i]) / (2 * h));
      dx_ds.push_back(std::move(d));
    }
    for (size_t k = 0; k < use.size(); ++k) {
      const size_t i = use[k];
      const Eigen::Vector2d residual = ph.detected_px[i] - q[k];
      worst_residual_diff =
          std::max(worst_residual_diff, (residual - m.residual_px[static_cast<size_t>(p)][i]).cwiseAbs().maxCoeff());
      Eigen::Matrix<double, 2, Eigen::Dynamic> row = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, cols);
      row.middleCols<3>(6L * p) = -dq_dp[k] * Skew(x[k]);  // d(w x X)/dw = -[X]x
      row.middleCols<3>(6L * p + 3) = dq_dp[k];
      for (long s = 0; s < ns; ++s) row.col(6L * np + s) = dq_dp[k] * dx_ds[static_cast<size_t>(s)][k];
      row.rightCols(ni) = dq_di[k];
      rows.push_back(std::move(row));
      detected.push_back(ph.detected_px[i]);
    }
  }
  const long n = static_cast<long>(rows.size());
  out.observations = static_cast<int>(n);
  out.residual_check_px = worst_residual_diff;
  if (n < cols) {
    out.note = fmt::format("{} inliers for {} parameters", n, cols);
    return out;
  }
  Eigen::MatrixXd j(2 * n, cols);
  for (long i = 0; i < n; ++i) j.middleRows<2>(2 * i) = rows[static_cast<size_t>(i)];
  Eigen::VectorXd scale = j.colwise().norm().transpose();
  for (long c = 0; c < cols; ++c) scale[c] = scale[c] > 0 ? 1 / scale[c] : 0;
  const Eigen::MatrixXd js = j * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(js.transpose() * js);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double cut = 1e-12 * std::max(ev.maxCoeff(), 1e-300);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(ev.size());
  for (long i = 0; i < ev.size(); ++i) inv[i] = ev[i] > cut ? 1 / ev[i] : 0;
  const Eigen::MatrixXd vs = scale.asDiagonal() * eig.eigenvectors();
  const Eigen::MatrixXd vi = vs.bottomRows(ni);                        // intrinsics rows of D V
  const Eigen::MatrixXd x_ii = vi * inv.asDiagonal() * vi.transpose();  // intrinsics block of (J^T J)^+
  const Eigen::MatrixXd a = (vi * inv.asDiagonal()) * (vs.transpose() * j.transpose());  // ni x 2n
  Eigen::MatrixXd ax(ni, n), ay(ni, n);
  for (long i = 0; i < n; ++i) ax.col(i) = a.col(2 * i), ay.col(i) = a.col(2 * i + 1);

  // 1. Detection noise: the fit's own covariance (noise_px^2 (J^T J)^-1, intrinsics block), checked against the
  //    rebuilt one.
  const Eigen::MatrixXd noise_rebuilt = m.noise_px * m.noise_px * x_ii;
  out.noise_check = (noise_rebuilt - m.intrinsics_covariance).norm() / std::max(1e-300, m.intrinsics_covariance.norm());
  FromScreenIntrinsicsBudget::Row noise;
  noise.name = "detection noise";
  noise.type = "A";
  noise.dof = m.dof;
  noise.covariance = m.intrinsics_covariance;
  noise.source = fmt::format("the fit's covariance: its residual noise {:.4f} px per coordinate squared times the "
                             "intrinsics block of the joint (J^T J)^-1 (marginal over the poses and the screen)",
                             m.noise_px);
  out.rows.push_back(noise);

  // 2. Detector systematic: the screen fit's smooth Legendre bias fields of RMS b, plus the pixel-locking signature
  //    at its bound (estimate + 2 sigma, phase unknown: the intrinsics are not corrected for it), propagated to the
  //    intrinsics.
  {
    const UncertaintyBudget& bud = m.budget;
    FromScreenIntrinsicsBudget::Row row;
    row.name = "detector systematic";
    row.type = "B";
    row.covariance = Eigen::MatrixXd::Zero(ni, ni);
    const double b = bud.systematic_bound_px;
    if (b > 0) {
      // Fields B c per coordinate with c ~ N(0, I), scaled to RMS b over the detections: E[c^T B^T B c] = tr(B^T B),
      // so Cov = b^2 n / tr(B^T B) (A_x B B^T A_x^T + A_y B B^T A_y^T) (the budget's seeded draws, in expectation).
      const Eigen::MatrixXd basis =
          LegendreFieldBasis(detected, model.width, model.height, options.systematic_field_degree);
      const double trace = basis.squaredNorm();
      if (trace > 0) {
        const Eigen::MatrixXd bx = ax * basis, by = ay * basis;
        row.covariance += b * b * static_cast<double>(n) / trace * (bx * bx.transpose() + by * by.transpose());
      }
    }
    const ResidualPixelLocking& pl = bud.pixel_locking;
    Eigen::Matrix2d bound = Eigen::Matrix2d::Zero();  // coordinate x period, as ResidualPixelLocking
    for (int c = 0; c < 2; ++c) {
      for (int t = 0; t < kPixelLockingTerms; ++t) {
        const double v = pl.amplitude_px(c, t) + 2 * pl.sigma_px(c, t);
        if (std::isfinite(v) && v > 0) bound(c, t) = v;
        if (!(bound(c, t) > 0)) continue;
        // A sin(2 pi phi + psi), phi the phase in the period, psi uniform: Cov = A^2 / 2 (A s s^T A^T + A k k^T A^T).
        Eigen::VectorXd sv(n), cv(n);
        for (long i = 0; i < n; ++i) {
          const double u = detected[static_cast<size_t>(i)][c] / kPixelLockingPeriods[static_cast<size_t>(t)];
          const double phase = kTwoPi * (u - std::floor(u));
          sv[i] = std::sin(phase);
          cv[i] = std::cos(phase);
        }
        const Eigen::MatrixXd& ac = c == 0 ? ax : ay;
        const Eigen::VectorXd gs = ac * sv, gc = ac * cv;
        row.covariance += 0.5 * bound(c, t) * bound(c, t) * (gs * gs.transpose() + gc * gc.transpose());
      }
    }
    row.source = fmt::format(
        "the screen fit's detector systematic propagated to the intrinsics: Legendre bias fields of total degree "
        "<= {} and RMS b = {:.4f} px per coordinate ({}), plus the pixel-locking signature, which the intrinsics "
        "are not corrected for, at its bound (estimate + 2 sigma, phase unknown; period 1 px: x {:.4f}, y {:.4f} px; "
        "period 2 px: x {:.4f}, y {:.4f} px)",
        options.systematic_field_degree, b, m.budget.systematic_bound_reason, bound(0, 0), bound(1, 0), bound(0, 1),
        bound(1, 1));
    out.rows.push_back(row);
  }

  // 3. Lens model misfit: the screen fit's measured fields (its components: Gaussian fields of variance s^2 and
  //    length L, ring fields of variance s^2 and period P, from the residuals' correlation at several lags),
  //    propagated to the intrinsics as the screen fit's budget propagates them (screen_fit_misfit.cc
  //    FieldVariance: the family's random-feature basis Phi, the same seeds, normalized by its mean variance v at
  //    the points): Cov = s^2 / v (A_x Phi Phi^T A_x^T + A_y Phi Phi^T A_y^T), the part of the lens's departure from
  //    its model that the intrinsics absorb where the screen was seen.
  {
    const UncertaintyBudget& bud = m.budget;
    FromScreenIntrinsicsBudget::Row row;
    row.name = "lens model misfit";
    row.type = "A";
    row.covariance = Eigen::MatrixXd::Zero(ni, ni);
    std::string parts;
    double var_sum = 0, dof_denominator = 0;
    for (const UncertaintyBudget::FieldComponent& f : bud.misfit_components) {
      if (!(f.variance_px2 > 0) || !(f.length_px > 0)) continue;
      const Eigen::MatrixXd phi = MisfitComponentFeatures(f, options).At(detected);
      const double basis_variance = phi.squaredNorm() / static_cast<double>(n);
      const Eigen::MatrixXd px = ax * phi, py = ay * phi;
      const Eigen::MatrixXd part = f.variance_px2 / basis_variance * (px * px.transpose() + py * py.transpose());
      row.covariance += part;
      out.unmodelled.push_back(f);
      out.unmodelled_variance_px2 += f.variance_px2;
      const bool ring = f.family == UncertaintyBudget::FieldFamily::kRing;
      parts += fmt::format("{}{} RMS {:.4f} px at a {} of {:.0f} px", parts.empty() ? "" : ", plus ",
                           ring ? "ring (band-pass)" : "Gaussian", std::sqrt(f.variance_px2),
                           ring ? "period" : "length", f.length_px);
      const double tr = part.diagonal().cwiseQuotient(m.intrinsics_covariance.diagonal().cwiseMax(1e-300)).sum();
      var_sum += tr;
      if (f.variance_sd_px2 > 0) {
        const double ratio = f.variance_px2 / f.variance_sd_px2;
        dof_denominator += tr * tr / (2 * ratio * ratio);
      }
    }
    if (dof_denominator > 0) row.dof = var_sum * var_sum / dof_denominator;
    row.source = parts.empty()
                     ? std::string("none measured (the screen fit's lens-model-misfit row is empty)")
                     : fmt::format("the screen fit's misfit fields ({}; stationary, the same in every photo, "
                                   "independent per coordinate, {} random Fourier features each) propagated to the "
                                   "intrinsics",
                                   parts, options.misfit_features);
    out.rows.push_back(row);
  }
  out.combined = Eigen::MatrixXd::Zero(ni, ni);
  for (const FromScreenIntrinsicsBudget::Row& r : out.rows) out.combined += r.covariance;
  // Welch-Satterthwaite over the rows, on the sum of the variances relative to the noise row's (the intrinsics'
  // units differ).
  const Eigen::VectorXd unit = m.intrinsics_covariance.diagonal().cwiseMax(1e-300);
  double total = 0, denominator = 0;
  for (const FromScreenIntrinsicsBudget::Row& r : out.rows) {
    const double v = r.covariance.diagonal().cwiseQuotient(unit).sum();
    total += v;
    if (std::isfinite(r.dof) && r.dof > 0) denominator += v * v / r.dof;
  }
  out.dof = denominator > 0 ? total * total / denominator : kInf;
  out.computed = out.noise_check < 0.05 && out.residual_check_px < 1e-3;
  if (!out.computed) {
    out.note = fmt::format("the rebuilt linearization does not reproduce the fit (residuals differ by up to {:.2g} px, "
                           "the noise covariance by {:.2g} relative)",
                           out.residual_check_px, out.noise_check);
  }
  return out;
}

}  // namespace curvecheck
