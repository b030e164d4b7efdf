// The detector's pixel-locking signature measured through the screen fit (analysis/screen_fit_internal.h): its
// shapes at the fit's predictions, its coefficients fitted on their refit projections, and the independent noise
// that remains once it is removed. The budget (screen_fit_budget.cc) propagates it; the lens-model-misfit
// statistics (screen_fit_misfit.cc) remove it first.
#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"
#include "core/error.h"

namespace curvecheck::screen_fit_internal {

// The pixel-locking signature's shapes at the active observations (2n x 4 kPixelLockingTerms, rows interleaved x,
// y): columns PixelLockingColumn(c, t) and the next hold sin and cos of 2 pi x the phase of coordinate c in period
// kPixelLockingPeriods[t] on that coordinate's rows, zero elsewhere. The phase is that of the fit's prediction
// (detected - residual), not of the detection: the detection's own noise e moves its phase by 2 pi e / T, and the
// shapes then correlate with the residual (-e) whatever the detector does (a regression on them found 0.29 +- 0.04
// px in pure 0.1 px noise on a 9 x 9 patch; ScreenFitTest.RelativeCurvatureSigmaLimitDropsTheRadiusNumber).
Eigen::MatrixXd PixelLockingShapes(const Setup& setup, const Linearization& lin, const Eigen::VectorXd& residual) {
  constexpr double kTwoPi = 6.283185307179586;
  const int n = static_cast<int>(lin.obs.size());
  Eigen::MatrixXd shapes = Eigen::MatrixXd::Zero(2 * n, 4 * kPixelLockingTerms);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d q = setup.obs[lin.obs[static_cast<size_t>(i)]].detected;
    if (residual.size() == 2 * n && residual.segment<2>(2 * i).allFinite()) q -= residual.segment<2>(2 * i);
    for (int c = 0; c < 2; ++c) {
      for (int t = 0; t < kPixelLockingTerms; ++t) {
        const double u = q[c] / kPixelLockingPeriods[static_cast<size_t>(t)], phase = kTwoPi * (u - std::floor(u));
        shapes(2 * i + c, PixelLockingColumn(c, t)) = std::sin(phase);
        shapes(2 * i + c, PixelLockingColumn(c, t) + 1) = std::cos(phase);
      }
    }
  }
  return shapes;
}

PixelLockingRegression FitPixelLocking(const Setup& setup, const Linearization& lin, const Eigen::VectorXd& residual) {
  PixelLockingRegression f;
  const Eigen::MatrixXd shapes = PixelLockingShapes(setup, lin, residual);
  f.projected = shapes - JTimes(lin, lin.normal_pinv * JtTimes(lin, shapes));
  f.normal = f.projected.transpose() * f.projected;
  const double n = static_cast<double>(lin.obs.size());
  f.ok = residual.size() == f.projected.rows() && residual.allFinite() && f.normal.diagonal().minCoeff() > 1e-9 * n;
  if (f.ok) f.coefficients = f.normal.ldlt().solve(f.projected.transpose() * residual);
  return f;
}

double IndependentNoisePx(const ModelFit& fit) {
  const double n = fit.budget.pixel_locking.noise_px;
  return std::isfinite(n) && n > 0 && fit.noise_px > 0 ? n : fit.noise_px;
}

ResidualPixelLocking EstimatePixelLockingThroughFit(const Setup& setup, const Linearization& lin,
                                                    const std::vector<Eigen::Vector2d>& residual_px,
                                                    int parameters) {
  ResidualPixelLocking out;
  const int n = static_cast<int>(lin.obs.size());
  out.observations = n;
  out.amplitude_px.setConstant(std::numeric_limits<double>::quiet_NaN());
  out.sigma_px = out.amplitude_px;
  if (static_cast<int>(residual_px.size()) != n) {
    throw Error("pixel-locking estimate", "residuals and linearization differ in number", "");
  }
  Eigen::VectorXd r(2 * n);
  for (int i = 0; i < n; ++i) r.segment<2>(2 * i) = residual_px[static_cast<size_t>(i)];
  const int dof = 2 * n - parameters - 4 * kPixelLockingTerms;
  const PixelLockingRegression f = FitPixelLocking(setup, lin, r);
  if (dof < 2 || !f.ok) return out;
  const double s2 = (r - f.projected * f.coefficients).squaredNorm() / dof;
  out.noise_px = std::sqrt(s2);
  const Eigen::MatrixXd cov = s2 * f.normal.inverse();
  for (int c = 0; c < 2; ++c) {
    for (int t = 0; t < kPixelLockingTerms; ++t) {
      const long col = PixelLockingColumn(c, t);
      const Eigen::Vector2d ab = f.coefficients.segment<2>(col);
      const Eigen::Matrix2d cc = cov.block<2, 2>(col, col);
      const double a = ab.norm();
      out.amplitude_px(c, t) = a;
      const double rms_sigma = std::sqrt(0.5 * cc.trace());
      out.sigma_px(c, t) = a > 3 * rms_sigma ? std::sqrt((ab / a).dot(cc * (ab / a))) : rms_sigma;
    }
  }
  return out;
}

}  // namespace curvecheck::screen_fit_internal
