#include "analysis/error_field.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <utility>

#include "core/error.h"
#include "core/stats.h"

namespace curvecheck {
namespace {

constexpr double kZ975 = 1.959963984540054;

// Legendre polynomials P_0..P_degree at x (Bonnet's recursion).
Eigen::VectorXd Legendre(double x, int degree) {
  Eigen::VectorXd p(degree + 1);
  p(0) = 1;
  if (degree >= 1) p(1) = x;
  for (int k = 2; k <= degree; ++k) p(k) = ((2 * k - 1) * x * p(k - 1) - (k - 1) * p(k - 2)) / k;
  return p;
}

// The Student-t 97.5% quantile over the normal one at `dof` (Cornish-Fisher expansion, within 0.1% for
// dof >= 5): the band's allowance for sigma being estimated.
double StudentOverNormal(double dof) {
  if (!(dof > 0)) return std::numeric_limits<double>::infinity();
  const double z = kZ975, z3 = z * z * z, z5 = z3 * z * z;
  const double t = z + (z3 + z) / (4 * dof) + (5 * z5 + 16 * z3 + 3 * z) / (96 * dof * dof);
  return t / z;
}

struct Box {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero(), half = Eigen::Vector2d::Ones();
  Eigen::Vector2d Normalize(const Eigen::Vector2d& d) const {
    return {(d.x() - centre.x()) / half.x(), (d.y() - centre.y()) / half.y()};
  }
};

// Basis values B(d) (length (du + 1)(dv + 1)) at a normalized position.
Eigen::VectorXd Basis(const Eigen::Vector2d& x, int du, int dv) {
  const Eigen::VectorXd pu = Legendre(x.x(), du), pv = Legendre(x.y(), dv);
  Eigen::VectorXd b((du + 1) * (dv + 1));
  for (int j = 0; j <= dv; ++j) {
    for (int i = 0; i <= du; ++i) b(j * (du + 1) + i) = pu(i) * pv(j);
  }
  return b;
}

// One fit of the field at degrees (du, dv) over the rows of `use`.
struct LevelFit {
  int du = 0, dv = 0, parameters = 0;
  int extra = 0;  // pixel-locking coefficients after the field's (0 or 4)
  double rss = 0, dof = 0, effective = 0, bic = std::numeric_limits<double>::infinity();
  Eigen::VectorXd coefficients;  // [c_x; c_y; pixel-locking]
  Eigen::MatrixXd pinv;          // A^+ (parameters x rows)
  std::vector<Eigen::Vector2d> residual;  // per feature (all features), camera px
  bool ok = false;
};

LevelFit FitLevel(const ErrorFieldInput& in, const std::vector<Eigen::Vector2d>& xs, const std::vector<bool>& use,
                  const Eigen::MatrixXd& q_nuisance, int du, int dv, bool pixel_locking = false) {
  LevelFit f;
  f.du = du;
  f.dv = dv;
  const int nb = (du + 1) * (dv + 1);
  f.parameters = 2 * nb;
  f.extra = pixel_locking ? 4 : 0;
  const int columns = f.parameters + f.extra;
  std::vector<int> rows;
  for (size_t i = 0; i < use.size(); ++i) {
    if (use[i]) rows.push_back(static_cast<int>(i));
  }
  const int m = 2 * static_cast<int>(rows.size());
  if (3 * columns > m) return f;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, columns);
  Eigen::VectorXd r(m);
  for (size_t k = 0; k < rows.size(); ++k) {
    const int i = rows[k];
    const Eigen::VectorXd b = Basis(xs[static_cast<size_t>(i)], du, dv);
    const Eigen::Matrix2d& j = in.jacobian[static_cast<size_t>(i)];
    for (int row = 0; row < 2; ++row) {
      a.block(2 * static_cast<int>(k) + row, 0, 1, nb) = j(row, 0) * b.transpose();
      a.block(2 * static_cast<int>(k) + row, nb, 1, nb) = j(row, 1) * b.transpose();
    }
    if (f.extra > 0) a.block<2, 4>(2 * static_cast<Eigen::Index>(k), f.parameters) = PixelLocking::Basis(in.camera_px[static_cast<size_t>(i)]);
    r.segment<2>(2 * static_cast<Eigen::Index>(k)) = in.residual_px[static_cast<size_t>(i)];
  }
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
  const int rank = static_cast<int>(cod.rank());
  f.pinv = cod.pseudoInverse();
  f.coefficients = f.pinv * r;
  const Eigen::VectorXd res = r - a * f.coefficients;
  f.rss = res.squaredNorm();
  // tr(P_A P_H) = ||Q_A^T Q_H||_F^2 over the rows used.
  double overlap = 0;
  if (q_nuisance.cols() > 0 && rank > 0) {
    Eigen::MatrixXd qh(m, q_nuisance.cols());
    for (size_t k = 0; k < rows.size(); ++k) qh.middleRows(2 * static_cast<Eigen::Index>(k), 2) = q_nuisance.middleRows(2 * rows[k], 2);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr_h(qh);
    const Eigen::MatrixXd qh_orth = qr_h.householderQ() * Eigen::MatrixXd::Identity(m, qh.cols());
    // tr(Q_H^T A A^+ Q_H), without forming the m x m projector.
    overlap = ((qh_orth.transpose() * a) * (f.pinv * qh_orth)).trace();
  }
  f.effective = rank - overlap;
  const double k = static_cast<double>(q_nuisance.cols());
  f.dof = m - k - f.effective;
  if (!(f.dof > 2)) return f;
  f.bic = m * std::log(std::max(f.rss, 1e-300) / m) + 2 * (k + f.effective);
  f.residual.assign(in.display_px.size(), Eigen::Vector2d::Zero());
  for (size_t i = 0; i < in.display_px.size(); ++i) {
    const Eigen::VectorXd b = Basis(xs[i], du, dv);
    const Eigen::Vector2d field(b.dot(f.coefficients.head(nb)), b.dot(f.coefficients.segment(nb, nb)));
    f.residual[i] = in.residual_px[i] - in.jacobian[i] * field;
    if (f.extra > 0) f.residual[i] -= PixelLocking::Basis(in.camera_px[i]) * f.coefficients.tail<4>();
  }
  f.ok = true;
  return f;
}

// Field values at the features for a fit's coefficients.
std::vector<Eigen::Vector2d> FieldValues(const std::vector<Eigen::Vector2d>& xs, const LevelFit& f) {
  const int nb = f.parameters / 2;
  std::vector<Eigen::Vector2d> v(xs.size());
  for (size_t i = 0; i < xs.size(); ++i) {
    const Eigen::VectorXd b = Basis(xs[i], f.du, f.dv);
    v[i] = {b.dot(f.coefficients.head(nb)), b.dot(f.coefficients.segment(nb, nb))};
  }
  return v;
}

// The ladder's best level by AIC over the rows of `use` (AIC rather than BIC: a field that is too poor leaves a
// bias the band does not cover, one that is too rich only widens the band), and the next level up that fits.
std::pair<LevelFit, LevelFit> ChooseLevel(const ErrorFieldInput& in, const std::vector<Eigen::Vector2d>& xs,
                                          const std::vector<bool>& use, const Eigen::MatrixXd& q_nuisance,
                                          int max_degree, double aspect, bool vary_u, bool vary_v) {
  std::vector<LevelFit> fits;
  for (int level = 0; level <= max_degree; level += level < 6 ? 1 : 2) {
    const int du = vary_u ? level : 0;
    const int dv = vary_v ? static_cast<int>(std::lround(level * (vary_u ? aspect : 1.0))) : 0;
    if (!fits.empty() && du == fits.back().du && dv == fits.back().dv) continue;
    LevelFit f = FitLevel(in, xs, use, q_nuisance, du, dv);
    if (!f.ok) {
      if (3 * (f.parameters + f.extra) > 2 * static_cast<int>(std::count(use.begin(), use.end(), true))) break;
      continue;
    }
    fits.push_back(std::move(f));
  }
  size_t best = 0;
  for (size_t i = 1; i < fits.size(); ++i) {
    if (fits[i].bic < fits[best].bic) best = i;
  }
  if (fits.empty()) return {};
  return {fits[best], best + 1 < fits.size() ? fits[best + 1] : LevelFit{}};
}

double MaxDistance(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}

// Cov(c) / sigma^2 = A^+ A^+^T - (A^+ Q_H)(A^+ Q_H)^T, over the rows of `use`.
Eigen::MatrixXd Covariance(const LevelFit& fit, const Eigen::MatrixXd& q_nuisance, const std::vector<bool>& use) {
  const Eigen::Index m = fit.pinv.cols();
  Eigen::MatrixXd qh(m, q_nuisance.cols());
  for (size_t i = 0, k = 0; i < use.size(); ++i) {
    if (!use[i]) continue;
    qh.middleRows(2 * static_cast<Eigen::Index>(k), 2) = q_nuisance.middleRows(2 * static_cast<Eigen::Index>(i), 2);
    ++k;
  }
  Eigen::MatrixXd cov = fit.pinv * fit.pinv.transpose();
  if (qh.cols() > 0) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr_h(qh);
    const Eigen::MatrixXd qh_orth = qr_h.householderQ() * Eigen::MatrixXd::Identity(m, qh.cols());
    const Eigen::MatrixXd aq = fit.pinv * qh_orth;
    cov -= aq * aq.transpose();
  }
  return cov;
}

}  // namespace

Eigen::Matrix<double, 2, 4> PixelLocking::Basis(const Eigen::Vector2d& camera_px) {
  constexpr double kTwoPi = 6.283185307179586;
  Eigen::Matrix<double, 2, 4> b = Eigen::Matrix<double, 2, 4>::Zero();
  b(0, 0) = std::sin(kTwoPi * camera_px.x());
  b(0, 1) = std::cos(kTwoPi * camera_px.x());
  b(1, 2) = std::sin(kTwoPi * camera_px.y());
  b(1, 3) = std::cos(kTwoPi * camera_px.y());
  return b;
}

Eigen::Vector2d PixelLocking::BiasAt(const Eigen::Vector2d& camera_px) const {
  return estimated ? Eigen::Vector2d(Basis(camera_px) * coefficients) : Eigen::Vector2d::Zero();
}

Eigen::Vector2d PixelLocking::Amplitude() const {
  return {std::hypot(coefficients(0), coefficients(1)), std::hypot(coefficients(2), coefficients(3))};
}

ErrorField EstimateErrorField(const ErrorFieldInput& in, const ErrorFieldOptions& options) {
  const size_t n = in.display_px.size();
  if (in.jacobian.size() != n || in.residual_px.size() != n || (!in.camera_px.empty() && in.camera_px.size() != n) ||
      (in.nuisance.size() > 0 && in.nuisance.rows() != 2 * static_cast<Eigen::Index>(n))) {
    throw Error("error field", fmt::format("{} positions, {} Jacobians, {} residuals and {} nuisance rows do not match",
                                           n, in.jacobian.size(), in.residual_px.size(), in.nuisance.rows()));
  }
  if (n < 4) throw Error("error field", fmt::format("only {} features; at least 4 are needed", n));

  // Normalized positions over the features' bounding box.
  Eigen::Vector2d lo = in.display_px[0], hi = in.display_px[0];
  for (const Eigen::Vector2d& d : in.display_px) lo = lo.cwiseMin(d), hi = hi.cwiseMax(d);
  Box box;
  box.centre = 0.5 * (lo + hi);
  box.half = (0.5 * (hi - lo)).cwiseMax(1e-9);
  const bool vary_u = hi.x() - lo.x() > 1e-6, vary_v = hi.y() - lo.y() > 1e-6;
  const double aspect = vary_u && vary_v ? (hi.y() - lo.y()) / (hi.x() - lo.x()) : 1.0;
  std::vector<Eigen::Vector2d> xs(n);
  for (size_t i = 0; i < n; ++i) xs[i] = box.Normalize(in.display_px[i]);

  // An orthonormal basis of the nuisance columns (the homography's directions).
  Eigen::MatrixXd q_nuisance(2 * static_cast<Eigen::Index>(n), 0);
  if (in.nuisance.cols() > 0) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(in.nuisance);
    const Eigen::Index rank = qr.rank();
    q_nuisance = (qr.householderQ() * Eigen::MatrixXd::Identity(in.nuisance.rows(), in.nuisance.cols()))
                     .leftCols(rank);
  }

  // Choose, flag outliers at the chosen level, choose again on the inliers (twice).
  std::vector<bool> use(n, true);
  LevelFit fit, next;
  std::tie(fit, next) = ChooseLevel(in, xs, use, q_nuisance, options.max_degree, aspect, vary_u, vary_v);
  for (int round = 0; round < 2 && fit.ok; ++round) {
    std::vector<double> a;
    for (size_t i = 0; i < n; ++i) {
      if (!use[i]) continue;
      a.push_back(std::abs(fit.residual[i].x()));
      a.push_back(std::abs(fit.residual[i].y()));
    }
    const double robust = std::max(1.4826 * Median(std::move(a)), options.outlier_floor_px);
    std::vector<bool> inlier(n, true);
    for (size_t i = 0; i < n; ++i) {
      inlier[i] = !(fit.residual[i].cwiseAbs().maxCoeff() > options.outlier_sigmas * robust);
    }
    if (inlier == use || std::count(inlier.begin(), inlier.end(), true) < static_cast<long>(n / 2)) break;
    use = inlier;
    std::tie(fit, next) = ChooseLevel(in, xs, use, q_nuisance, options.max_degree, aspect, vary_u, vary_v);
  }
  if (!fit.ok) {
    throw Error("error field", fmt::format("{} features leave no degrees of freedom for a field and its noise", n));
  }

  ErrorField out;
  out.degree_u = fit.du;
  out.degree_v = fit.dv;
  out.parameters = fit.parameters;
  out.dof = fit.dof;
  out.noise_px = std::sqrt(fit.rss / fit.dof);
  out.outlier.resize(n);
  for (size_t i = 0; i < n; ++i) out.outlier[i] = !use[i];

  Eigen::MatrixXd cov = Covariance(fit, q_nuisance, use);
  cov *= out.noise_px * out.noise_px;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (cov + cov.transpose()));
  const Eigen::MatrixXd root = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0).cwiseSqrt().asDiagonal();

  const int nb = fit.parameters / 2;
  std::vector<Eigen::VectorXd> basis(n);
  out.value.resize(n);
  out.covariance.resize(n);
  double sum_var = 0;
  for (size_t i = 0; i < n; ++i) {
    basis[i] = Basis(xs[i], fit.du, fit.dv);
    const Eigen::VectorXd& b = basis[i];
    out.value[i] = {b.dot(fit.coefficients.head(nb)), b.dot(fit.coefficients.segment(nb, nb))};
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(2, fit.parameters);
    g.block(0, 0, 1, nb) = b.transpose();
    g.block(1, nb, 1, nb) = b.transpose();
    out.covariance[i] = g * cov * g.transpose();
    sum_var += out.covariance[i].trace();
  }
  out.rms_sigma_display_px = std::sqrt(sum_var / static_cast<double>(n));
  // Pixel-locking: refitted at the chosen level with its four columns beside the field's, over the same
  // features. The field, the noise and the band above stay those of the field alone: with the pixel-locking
  // removed the scatter of a clean photo falls to a few thousandths of a pixel, and the degree chosen against
  // it would then chase the detector's smaller biases (on an exact rendering at quarter resolution it chose
  // degree 5 and e = 0.23 display px, against e = 0.002 at degree 1 without the term).
  if (!in.camera_px.empty()) {
    const LevelFit pl = FitLevel(in, xs, use, q_nuisance, fit.du, fit.dv, true);
    if (pl.ok) {
      out.pixel_locking.estimated = true;
      out.pixel_locking.coefficients = pl.coefficients.tail<4>();
      out.pixel_locking.covariance = Covariance(pl, q_nuisance, use).bottomRightCorner<4, 4>() * (pl.rss / pl.dof);
      out.pixel_locking.noise_px = std::sqrt(pl.rss / pl.dof);
    }
  }

  // The simultaneous band by Monte Carlo.
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal;
  std::vector<double> maxima;
  maxima.reserve(static_cast<size_t>(options.draws));
  Eigen::VectorXd w(fit.parameters);
  for (int d = 0; d < options.draws; ++d) {
    for (int k = 0; k < w.size(); ++k) w(k) = normal(rng);
    const Eigen::VectorXd z = root * w;
    double largest = 0;
    for (size_t i = 0; i < n; ++i) {
      const double dx = basis[i].dot(z.head(nb)), dy = basis[i].dot(z.segment(nb, nb));
      largest = std::max(largest, std::hypot(dx, dy));
    }
    maxima.push_back(largest);
  }
  // The choice of degree: what the next level up changes (its bias if the chosen level is too poor, its noise
  // otherwise), added in quadrature to the estimation band.
  if (next.ok) out.selection_display_px = MaxDistance(FieldValues(xs, next), out.value);
  const double band = Percentile(std::move(maxima), 95) * StudentOverNormal(out.dof);
  out.band95_display_px = std::hypot(band, out.selection_display_px);
  return out;
}

}  // namespace curvecheck
