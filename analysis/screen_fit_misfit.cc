// The lens-model-misfit row of the uncertainty budget (analysis/screen_fit_internal.h): the misfit field's RMS
// and correlation length measured from the residuals' correlation between features, and its propagation.
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "analysis/screen_fit_internal.h"

namespace curvecheck::screen_fit_internal {
namespace {

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
    // Row-major: the pair sums below read whole rows (400 features each); column-major rows are strided by 2n and
    // made this loop half of analyze's time on one photo (perf).
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const RowMajor rx = dx - jp * (lin.j_obs.transpose() * dx);
    const RowMajor ry = dy - jp * (lin.j_obs.transpose() * dy);
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


}  // namespace

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

}  // namespace curvecheck::screen_fit_internal
