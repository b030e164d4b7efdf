// The lens-model-misfit row of the uncertainty budget (analysis/screen_fit_internal.h): the misfit field's RMS
// and correlation length measured from the residuals' correlation between features, and its propagation.
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "analysis/screen_fit_internal.h"
#include "core/parallel.h"

namespace curvecheck::screen_fit_internal {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// One photo's rows of the observations' Jacobian (2n x t, coordinates interleaved), dense over the columns that any
// of them touches (its pose's and the shared ones: the shape, the deviation field, free intrinsics): rows (indices
// into lin.obs, ascending), their detected points, cols (ascending) and J_x, J_y on them (rows 2i and 2i + 1 of
// j_obs).
struct PhotoBlock {
  std::vector<int> rows;
  std::vector<Eigen::Vector2d> points;
  std::vector<long> cols;
  std::array<RowMajor, 2> j;
};

std::vector<PhotoBlock> PhotoBlocks(const Setup& setup, const Linearization& lin) {
  std::vector<PhotoBlock> blocks(static_cast<size_t>(setup.photos));
  for (size_t r = 0; r < lin.obs.size(); ++r) {
    blocks[static_cast<size_t>(setup.obs[lin.obs[r]].photo)].rows.push_back(static_cast<int>(r));
  }
  std::vector<PhotoBlock> out;
  for (PhotoBlock& block : blocks) {
    if (block.rows.empty()) continue;
    for (const int r : block.rows) block.points.push_back(setup.obs[lin.obs[static_cast<size_t>(r)]].detected);
    for (long c = 0; c < lin.j_obs.cols(); ++c) {
      const bool used = std::any_of(block.rows.begin(), block.rows.end(), [&](int r) {
        return lin.j_obs(2L * r, c) != 0 || lin.j_obs(2L * r + 1, c) != 0;
      });
      if (used) block.cols.push_back(c);
    }
    for (long f = 0; f < 2; ++f) {
      RowMajor& j = block.j[static_cast<size_t>(f)];
      j.resize(static_cast<long>(block.rows.size()), static_cast<long>(block.cols.size()));
      for (size_t r = 0; r < block.rows.size(); ++r) {
        for (size_t c = 0; c < block.cols.size(); ++c) {
          j(static_cast<long>(r), static_cast<long>(c)) = lin.j_obs(2L * block.rows[r] + f, block.cols[c]);
        }
      }
    }
    out.push_back(std::move(block));
  }
  return out;
}

// The median distance from each observation to its nearest neighbour in the same photo, over all observations
// (Setup::cache, computed once per fit): the unit of the lags and of the candidates' lengths.
double FeatureSpacing(const Setup& setup) {
  if (setup.cache->spacing_px > 0) return setup.cache->spacing_px;
  std::vector<std::vector<size_t>> in_photo(static_cast<size_t>(setup.photos));
  for (size_t i = 0; i < setup.obs.size(); ++i) in_photo[static_cast<size_t>(setup.obs[i].photo)].push_back(i);
  std::vector<double> nn;
  for (const std::vector<size_t>& photo : in_photo) {
    for (const size_t a : photo) {
      double best = kInf;
      for (const size_t b : photo) {
        if (b != a) best = std::min(best, (setup.obs[b].detected - setup.obs[a].detected).squaredNorm());
      }
      if (std::isfinite(best)) nn.push_back(std::sqrt(best));
    }
  }
  if (nn.size() < 8) return 0;
  std::nth_element(nn.begin(), nn.begin() + static_cast<long>(nn.size() / 2), nn.end());
  setup.cache->spacing_px = nn[nn.size() / 2];
  return setup.cache->spacing_px;
}

// J_f^T Phi for both coordinates f (t x D each), Phi the basis of `features` at the active observations, summed
// photo by photo over the dense blocks (a photo's rows of Phi evaluated at a time, into *phi); and the sum of Phi's
// squares. With `solve` (PixelLockingCorrection::solve, 4 kPixelLockingTerms x 2n) also M_f Phi into *m_phi.
std::array<RowMajor, 2> JacobianTimesBasis(const Linearization& lin, const std::vector<PhotoBlock>& blocks,
                                           const FieldFeatures& features, RowMajor* phi, double* phi_squared,
                                           const Eigen::MatrixXd* solve = nullptr,
                                           std::array<Eigen::MatrixXd, 2>* m_phi = nullptr) {
  const long t = lin.j_obs.cols(), d = features.omega.rows();
  std::array<RowMajor, 2> jtp = {RowMajor::Zero(t, d), RowMajor::Zero(t, d)};
  if (solve) *m_phi = {Eigen::MatrixXd::Zero(solve->rows(), d), Eigen::MatrixXd::Zero(solve->rows(), d)};
  *phi_squared = 0;
  RowMajor part;
  Eigen::MatrixXd m_block;
  for (const PhotoBlock& block : blocks) {
    features.Evaluate(block.points, phi);
    *phi_squared += phi->squaredNorm();
    for (size_t f = 0; f < 2; ++f) {
      part.noalias() = block.j[f].transpose() * *phi;
      for (size_t c = 0; c < block.cols.size(); ++c) jtp[f].row(block.cols[c]) += part.row(static_cast<long>(c));
      if (!solve) continue;
      m_block.resize(solve->rows(), static_cast<long>(block.rows.size()));
      for (size_t r = 0; r < block.rows.size(); ++r) {
        m_block.col(static_cast<long>(r)) = solve->col(2L * block.rows[r] + static_cast<long>(f));
      }
      (*m_phi)[f].noalias() += m_block * *phi;
    }
  }
  return jtp;
}

// Each active observation paired with its nearest neighbour in the same photo (indices into lin.obs); candidates
// in ascending order, so the first of equally near neighbours wins.
std::vector<std::pair<int, int>> NeighbourPairs(const Setup& setup, const Linearization& lin) {
  const int n = static_cast<int>(lin.obs.size());
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
  return pairs;
}

// The covariance of the lag statistics S_j = mean over bin j's pairs of r_a . r_b / 2, for Gaussian residuals of
// covariance C per coordinate (independent coordinates): by Isserlis' theorem cov(x_a x_b, x_c x_d) = C_ac C_bd +
// C_ad C_bc, so cov(S_j, S_k) = sum over the pairs (a, b) of j and (c, d) of k of (C_ac C_bd + C_ad C_bc) /
// (2 N_j N_k). C between two residuals: `var0` for the same one; else the residuals' correlation at their distance
// (`by_lag`, per lag bin: the fitted field's share, common to every photo, plus within a photo the refit's share
// `noise_by_lag`), 0 beyond the last bin. The double sum is estimated on at most kSub evenly spread pairs per bin,
// the pair-with-itself terms (N_j of them) apart from the others.
Eigen::MatrixXd StatisticsCovariance(const Setup& setup, const Linearization& lin,
                                     const std::vector<Eigen::Vector2d>& points, double spacing,
                                     const std::array<double, 10>& edges, const std::vector<double>& by_lag,
                                     const std::vector<double>& noise_by_lag, double var0,
                                     const std::vector<std::vector<std::pair<int, int>>>& bin_pairs) {
  constexpr size_t kSub = 100;
  const size_t m = bin_pairs.size();
  std::array<double, 10> edge2{};
  for (size_t e = 0; e < edges.size(); ++e) edge2[e] = edges[e] * edges[e] * spacing * spacing;
  const auto photo = [&](int a) { return setup.obs[lin.obs[static_cast<size_t>(a)]].photo; };
  const auto cov = [&](int a, int b) {
    if (a == b) return var0;
    const double d2 = (points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).squaredNorm();
    size_t j = 0;
    while (j + 1 < edge2.size() && d2 >= edge2[j + 1]) ++j;
    if (j + 1 >= edge2.size()) return 0.0;
    return by_lag[j] + (photo(a) == photo(b) ? noise_by_lag[j] : 0.0);
  };
  std::vector<std::vector<std::pair<int, int>>> sub(m);
  for (size_t j = 0; j < m; ++j) {
    const auto& all = bin_pairs[j];
    const size_t take = std::min(all.size(), kSub);
    for (size_t i = 0; i < take; ++i) sub[j].push_back(all[i * all.size() / take]);
  }
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(static_cast<long>(m), static_cast<long>(m));
  for (size_t j = 0; j < m; ++j) {
    const double nj = static_cast<double>(bin_pairs[j].size());
    for (size_t k = j; k < m; ++k) {
      const double nk = static_cast<double>(bin_pairs[k].size());
      double off = 0, self = 0;
      for (size_t p = 0; p < sub[j].size(); ++p) {
        const auto [a, b] = sub[j][p];
        for (size_t q = 0; q < sub[k].size(); ++q) {
          const auto [c, d] = sub[k][q];
          const double t = cov(a, c) * cov(b, d) + cov(a, d) * cov(b, c);
          if (j == k && p == q) self += t;
          else off += t;
        }
      }
      const double ms = static_cast<double>(sub[j].size()), mk = static_cast<double>(sub[k].size());
      double sum = off / (ms * mk - (j == k ? ms : 0.0)) * (nj * nk - (j == k ? nj : 0.0));
      if (j == k) sum += self / ms * nj;
      out(static_cast<long>(j), static_cast<long>(k)) = out(static_cast<long>(k), static_cast<long>(j)) =
          sum / (2.0 * nj * nk);
    }
  }
  return out;
}

}  // namespace

std::optional<Eigen::MatrixXd> EstimatedCovarianceWeight(const Eigen::MatrixXd& covariance) {
  if (covariance.size() == 0) return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(covariance);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().maxCoeff() > 0)) {
    return std::nullopt;
  }
  const double floor =
      std::max(1e-6 * eig.eigenvalues().maxCoeff(), std::max(0.0, -eig.eigenvalues().minCoeff()));
  const Eigen::VectorXd ev = eig.eigenvalues().cwiseMax(floor);
  return eig.eigenvectors() * ev.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

namespace {

// The correlated error's components (UncertaintyBudget::misfit_components, misfit_lags), from the residuals'
// correlation at several lags. The neighbour statistic alone cannot tell a field smooth over the whole image (which
// moves the radius) from errors correlated over a few features only (the detector's pixel-locking beat,
// demosaicing, moire: they average out over the board): propagated as a smooth field, the latter gave radius
// sigmas 1.4-3x the scatter of seeded trials (bench validity, realistic camera). Per lag bin j (pairs in the same
// photo at distances between kLagEdges feature spacings), S_j = mean of r_a . r_b / 2 has
// E[S_j] = sum_c s_c^2 kappa_j(c) + sigma^2 nu_j: kappa_j(c) the same mean for a stationary field of unit variance
// of component c's family after the linearized refit, exactly from its random-feature basis Phi
// (E[e_a . e_b] = (R R^T)_ab, R = (I - J (J^T J)^+ J^T) Phi), nu_j the refit's share -(J (J^T J)^+ J^T)_ab.
// Two families: Gaussian fields (covariance exp(-d^2 / 2 L^2), L of 1 to 32 feature spacings, at most the image
// width), positive at every lag, and ring fields (covariance J0(2 pi d / P), P of 3 to 24 spacings), band-pass
// processes whose correlation changes sign, as a beat between the features' spacing and a pixel grid does (the
// residuals of frontal photos of the realistic camera correlate positively at 1-2 spacings and negatively at ~9:
// fitted by Gaussians alone, that beat was taken for a long-range field and the radius sigma came out ~2x the
// scatter on axis). The variances s_c^2 >= 0 of up to two Gaussian components and one ring are fitted by weighted
// least squares for every combination of the candidate scales; the combination of the smallest weighted misfit
// plus twice its number of components (AIC) is kept, with the variances' standard errors (scaled by the fit's
// own scatter when it exceeds them). Pairs beyond kMaxPairsPerLag per bin are thinned evenly.
void EstimateMisfitCorrelation(const Setup& setup, const Linearization& lin,
                               const std::vector<Eigen::Vector2d>& residual, double sigma_px,
                               const std::vector<std::pair<int, int>>& neighbours, UncertaintyBudget* bud) {
  constexpr size_t kMaxPairsPerLag = 2000;
  constexpr std::array<double, 10> kLagEdges = {0, 1.5, 2.5, 3.5, 5, 7, 10, 14, 20, 28};
  const int n = static_cast<int>(lin.obs.size());
  const std::vector<Eigen::Vector2d> points = DetectedPoints(setup, lin);
  const double spacing = FeatureSpacing(setup);
  if (neighbours.size() < 8 || !(sigma_px > 0) || !(spacing > 0)) return;
  const size_t bins = kLagEdges.size() - 1;
  std::vector<std::vector<std::pair<int, int>>> lag(bins);
  std::vector<std::vector<int>> in_photo(static_cast<size_t>(setup.photos));  // ascending: the pairs' order is a, b
  for (int a = 0; a < n; ++a) in_photo[static_cast<size_t>(setup.obs[lin.obs[static_cast<size_t>(a)]].photo)].push_back(a);
  for (int a = 0; a < n; ++a) {
    for (const int b : in_photo[static_cast<size_t>(setup.obs[lin.obs[static_cast<size_t>(a)]].photo)]) {
      if (b <= a) continue;
      const double d = (points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).norm() / spacing;
      const auto j = std::upper_bound(kLagEdges.begin(), kLagEdges.end(), d) - kLagEdges.begin() - 1;
      if (j >= 0 && static_cast<size_t>(j) < bins) lag[static_cast<size_t>(j)].emplace_back(a, b);
    }
  }
  for (auto& l : lag) {
    if (l.size() <= kMaxPairsPerLag) continue;
    std::vector<std::pair<int, int>> thin;
    const double step = static_cast<double>(l.size()) / kMaxPairsPerLag;
    for (size_t i = 0; i < kMaxPairsPerLag; ++i) thin.push_back(l[static_cast<size_t>(i * step)]);
    l.swap(thin);
  }
  const Eigen::MatrixXd jp = JTimes(lin, lin.normal_pinv);  // 2n x t
  struct Bin { double lag = 0, stat = 0, nu = 0; int pairs = 0; };
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
    stats.push_back(bin);
    used_bins.push_back(j);
  }
  if (stats.size() < 2) return;
  // kappa_j of each candidate component. A field on coordinate f (phi on the rows of f, zero on the other) leaves,
  // on the rows of coordinate c, R_fc = delta_fc phi - J_c (J^T J)^+ J_f^T phi after the refit (J_c: the rows of J
  // of coordinate c, n x t). Own coordinate (f = c): R_ff = phi - J_f U_f, U_f = (J^T J)^+ J_f^T phi (t x D). The
  // other (f != c): R_fc = -J_c U_f, whose pair products are J_c,a (U_f U_f^T) J_c,b^T: through t x t matrices.
  // Pairs lie within one photo and a photo's rows of J are non-zero only in its own pose's and the shared columns,
  // so everything runs photo by photo on dense blocks (PhotoBlock): J_f^T phi summed over the photos, then per
  // photo R_ff's rows formed and the photo's pairs summed while they are in cache. (Formed for all photos at once,
  // the n x D matrices and the sparse products over them were memory-bound: ~100 ms per candidate at 10 photos.)
  const std::vector<PhotoBlock> blocks = PhotoBlocks(setup, lin);
  const size_t used = stats.size();
  std::vector<std::vector<std::vector<std::pair<int, int>>>> photo_pairs(
      blocks.size(), std::vector<std::vector<std::pair<int, int>>>(used));  // [block][used bin]: local rows
  {
    std::vector<std::pair<int, int>> local(static_cast<size_t>(n), {-1, -1});  // lin row -> (block, local row)
    for (size_t bi = 0; bi < blocks.size(); ++bi) {
      for (size_t r = 0; r < blocks[bi].rows.size(); ++r) {
        local[static_cast<size_t>(blocks[bi].rows[r])] = {static_cast<int>(bi), static_cast<int>(r)};
      }
    }
    for (size_t k = 0; k < used; ++k) {
      for (const auto& [a, b] : lag[used_bins[k]]) {
        const auto [ba, ra] = local[static_cast<size_t>(a)];
        const auto [bb, rb] = local[static_cast<size_t>(b)];
        if (ba < 0 || ba != bb) continue;  // not reached: the pairs are within one photo
        photo_pairs[static_cast<size_t>(ba)][k].emplace_back(ra, rb);
      }
    }
  }
  std::vector<UncertaintyBudget::FieldComponent> candidates;
  for (double factor : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0}) {
    const double length = std::min(factor * spacing, static_cast<double>(setup.camera->width));
    if (!candidates.empty() && length <= candidates.back().length_px) continue;
    candidates.push_back({UncertaintyBudget::FieldFamily::kGaussian, length, 0, 0});
  }
  const size_t gaussians = candidates.size();
  for (double factor : {3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0}) {
    if (factor * spacing > setup.camera->width) break;
    candidates.push_back({UncertaintyBudget::FieldFamily::kRing, factor * spacing, 0, 0});
  }
  // One candidate per core. Its basis is evaluated a photo at a time, twice (for U_f, then for the pairs): stored
  // for every observation, the 13 bases took 300 of the 450 ms of this function at ten photos (writing 210 MB of
  // fresh memory), where evaluating a photo's rows into a buffer that stays in cache costs a few ms.
  const long t = lin.normal_pinv.rows();
  std::vector<Eigen::VectorXd> kappas(candidates.size());
  ParallelFor(static_cast<int>(candidates.size()), [&](int ci) {
    const FieldFeatures field = MisfitComponentFeatures(candidates[static_cast<size_t>(ci)], *setup.options);
    const long features = field.omega.rows();
    RowMajor phi;  // one photo's rows of the basis
    // U_f = (J^T J)^+ J_f^T phi, J_f^T phi summed photo by photo.
    double phi_squared = 0;
    const std::array<RowMajor, 2> jtp = JacobianTimesBasis(lin, blocks, field, &phi, &phi_squared);
    std::array<RowMajor, 2> u;
    for (size_t f = 0; f < 2; ++f) u[f].noalias() = lin.normal_pinv * jtp[f];
    // The x field seen on y's rows (cross_y = U_x U_x^T), and vice versa.
    RowMajor cross_y(t, t), cross_x(t, t);
    cross_y.noalias() = u[0] * u[0].transpose();
    cross_x.noalias() = u[1] * u[1].transpose();
    Eigen::VectorXd sums = Eigen::VectorXd::Zero(static_cast<long>(used));
    std::array<RowMajor, 2> own, w;
    RowMajor u_block;
    for (size_t bi = 0; bi < blocks.size(); ++bi) {
      const PhotoBlock& block = blocks[bi];
      field.Evaluate(block.points, &phi);
      const long nc = static_cast<long>(block.cols.size());
      for (size_t f = 0; f < 2; ++f) {
        u_block.resize(nc, features);
        for (long c = 0; c < nc; ++c) u_block.row(c) = u[f].row(block.cols[static_cast<size_t>(c)]);
        own[f] = phi;
        own[f].noalias() -= block.j[f] * u_block;
        // J_c,a (U_f U_f^T) restricted to the block's columns (J_c,a is zero elsewhere): c = f's other coordinate.
        const RowMajor& cross = f == 0 ? cross_x : cross_y;
        RowMajor cross_block(nc, nc);
        for (long a = 0; a < nc; ++a) {
          for (long b = 0; b < nc; ++b) cross_block(a, b) = cross(block.cols[static_cast<size_t>(a)], block.cols[static_cast<size_t>(b)]);
        }
        w[f].noalias() = block.j[f] * cross_block;
      }
      for (size_t k = 0; k < used; ++k) {
        double sum = 0;
        for (const auto& [a, b] : photo_pairs[bi][k]) {
          sum += own[0].row(a).dot(own[0].row(b)) + own[1].row(a).dot(own[1].row(b)) +
                 w[0].row(a).dot(block.j[0].row(b)) + w[1].row(a).dot(block.j[1].row(b));
        }
        sums[static_cast<long>(k)] += sum;
      }
    }
    const double variance = phi_squared / n;  // the field's mean variance at the points (1 but for sampling)
    Eigen::VectorXd kappa(static_cast<long>(used));
    for (size_t k = 0; k < used; ++k) kappa[static_cast<long>(k)] = 0.5 * sums[static_cast<long>(k)] / stats[k].pairs / variance;
    kappas[static_cast<size_t>(ci)] = kappa;
  });
  // The statistics beyond the noise's share. Their covariance: pairs overlap (a feature is in many pairs) and the
  // residuals are correlated, so the pair products are not independent; a first selection weights the bins as if
  // they were (a product's variance about (sigma^2 + s^2)^2 / 2, s^2 from the nearest lag), then the statistics'
  // covariance is computed from that selection's residual covariance (StatisticsCovariance) and the selection is
  // repeated by generalized least squares (weighted by EstimatedCovarianceWeight: that covariance is itself an
  // estimate, often indefinite). Under independent weights the long lags' sums looked far more certain
  // than they are (a long-range Gaussian of variance 0.16 +- 0.012 px^2 in a frontal validity trial, its row 10 mm
  // against a scatter of ~4 mm).
  const long m = static_cast<long>(stats.size());
  Eigen::VectorXd y(m), nu(m);
  for (long k = 0; k < m; ++k) {
    nu[k] = sigma_px * sigma_px * stats[static_cast<size_t>(k)].nu;
    y[k] = stats[static_cast<size_t>(k)].stat - nu[k];
  }
  const double total = sigma_px * sigma_px + std::max(0.0, y[0]);
  Eigen::MatrixXd weight = Eigen::MatrixXd::Zero(m, m);
  for (long k = 0; k < m; ++k) weight(k, k) = 2.0 * stats[static_cast<size_t>(k)].pairs / (total * total);
  struct Choice {
    double cost = kInf;
    std::vector<std::pair<size_t, double>> parts;  // (candidate index, variance)
    Eigen::MatrixXd covariance;
  };
  const auto select = [&](const Eigen::MatrixXd& wm) {
    Choice best;
    const auto consider = [&](const std::vector<size_t>& idx) {
      const long p = static_cast<long>(idx.size());
      if (p >= m) return;
      Eigen::MatrixXd a(m, p);
      for (long c = 0; c < p; ++c) a.col(c) = kappas[idx[static_cast<size_t>(c)]];
      const Eigen::MatrixXd normal = a.transpose() * wm * a;
      if (normal.determinant() <= 1e-300 * std::pow(normal.norm(), static_cast<double>(p))) return;
      const Eigen::VectorXd x = normal.ldlt().solve(a.transpose() * wm * y);
      if ((x.array() < 0).any()) return;  // the fits with fewer components cover the boundary
      const Eigen::VectorXd e = y - a * x;
      const double cost = e.dot(wm * e) + 2.0 * p;
      if (cost >= best.cost) return;
      best.cost = cost;
      best.parts.clear();
      for (long c = 0; c < p; ++c) best.parts.emplace_back(idx[static_cast<size_t>(c)], x[c]);
      const double birge = std::max(1.0, (cost - 2.0 * p) / static_cast<double>(m - p));
      best.covariance = birge * normal.inverse();
    };
    // Up to two Gaussian components (short- and long-range) and one ring.
    for (size_t ring = gaussians; ring <= candidates.size(); ++ring) {
      std::vector<size_t> with_ring;
      if (ring < candidates.size()) with_ring.push_back(ring);
      if (!with_ring.empty()) consider(with_ring);
      for (size_t i = 0; i < gaussians; ++i) {
        std::vector<size_t> one = {i};
        one.insert(one.end(), with_ring.begin(), with_ring.end());
        consider(one);
        for (size_t j = i + 1; j < gaussians; ++j) {
          std::vector<size_t> two = {i, j};
          two.insert(two.end(), with_ring.begin(), with_ring.end());
          consider(two);
        }
      }
    }
    return best;
  };
  Choice best = select(weight);
  {
    // The residuals' covariance per coordinate as the first selection reproduces it, per lag bin (field and noise
    // shares), and at lag 0 the residuals' own variance.
    Eigen::VectorXd field = Eigen::VectorXd::Zero(m);
    for (const auto& [ci, v] : best.parts) field += v * kappas[ci];
    double var0 = 0;
    for (const Eigen::Vector2d& r : residual) var0 += 0.5 * r.squaredNorm() / n;
    std::vector<double> by_lag(bins + 1, 0.0), noise_by_lag(bins + 1, 0.0);  // unused bins: their nearest used one
    for (size_t j = 0; j < bins; ++j) {
      size_t near = 0;
      for (size_t k = 1; k < used_bins.size(); ++k) {
        if (std::abs(static_cast<double>(used_bins[k]) - static_cast<double>(j)) <
            std::abs(static_cast<double>(used_bins[near]) - static_cast<double>(j))) near = k;
      }
      by_lag[j] = field[static_cast<long>(near)];
      noise_by_lag[j] = nu[static_cast<long>(near)];
    }
    std::vector<std::vector<std::pair<int, int>>> sub(static_cast<size_t>(m));
    for (long k = 0; k < m; ++k) sub[static_cast<size_t>(k)] = lag[used_bins[static_cast<size_t>(k)]];
    const Eigen::MatrixXd cov_s = StatisticsCovariance(setup, lin, points, spacing, kLagEdges, by_lag, noise_by_lag,
                                                       var0, sub);
    if (std::optional<Eigen::MatrixXd> w = EstimatedCovarianceWeight(cov_s)) {
      weight = std::move(*w);
      best = select(weight);
    }
  }
  if (best.parts.empty()) {  // every fit was negative: no correlated error seen
    best.parts = {{gaussians - 1, 0.0}};
    const double kw = kappas[gaussians - 1].dot(weight * kappas[gaussians - 1]);
    best.covariance = Eigen::MatrixXd::Constant(1, 1, kw > 0 ? 1 / kw : kInf);
    best.cost = y.dot(weight * y) + 2.0;
  }
  bud->misfit_components.clear();
  Eigen::VectorXd model = Eigen::VectorXd::Zero(m);
  for (size_t c = 0; c < best.parts.size(); ++c) {
    const auto& [ci, v] = best.parts[c];
    UncertaintyBudget::FieldComponent component = candidates[ci];
    component.variance_px2 = v;
    component.variance_sd_px2 = std::sqrt(std::max(0.0, best.covariance(static_cast<long>(c), static_cast<long>(c))));
    bud->misfit_components.push_back(component);
    model += v * kappas[ci];
  }
  // The longest Gaussian component is the one that moves the radius most; the summary fields name it (the ring
  // when there is none).
  const UncertaintyBudget::FieldComponent* longest = &bud->misfit_components.back();
  for (const UncertaintyBudget::FieldComponent& c : bud->misfit_components) {
    if (c.family == UncertaintyBudget::FieldFamily::kGaussian) longest = &c;
  }
  bud->misfit_length_px = longest->length_px;
  bud->misfit_variance_px2 = longest->variance_px2;
  bud->misfit_variance_sd_px2 = longest->variance_sd_px2;
  bud->misfit_lags.clear();
  for (long k = 0; k < m; ++k) {
    const size_t kk = static_cast<size_t>(k);
    bud->misfit_lags.push_back({stats[kk].lag, stats[kk].pairs, stats[kk].stat, sigma_px * sigma_px * stats[kk].nu, model[k]});
  }
  bud->misfit_spacing_px = spacing;
  bud->misfit_fit_chi2 = best.cost;
}

// The first `rows` quantities' response to a field on coordinate f at the detections (rows x n): G_f, less
// G S M_f where the estimate is corrected for the pixel-locking signature (PixelLockingCorrection::Response).
Eigen::MatrixXd FieldResponse(const Linearization& lin, const PixelLockingCorrection& correction, int f, long rows) {
  const Eigen::MatrixXd jf = lin.j_obs(Eigen::seq(f, Eigen::last, 2), Eigen::all);  // J_f, n x t
  Eigen::MatrixXd a = lin.sel_pinv.topRows(rows) * jf.transpose();
  if (correction.ok) a -= correction.gs.topRows(rows) * correction.SolveColumns(f);
  return a;
}

}  // namespace

// A stationary field of one component's family and variance, common to every photo, propagated through G:
// cov(q) = A_x K A_x^T + A_y K A_y^T, K_ij = MisfitComponentCovariance(component, |p_i - p_j|) at the
// detections p_i (every photo's: the field is the lens's), A_f = G_f less G S M_f where the estimate is
// corrected for the pixel-locking signature. Exact up to kExactFieldPoints detections (kExactRingFieldPoints
// for a ring: n^2 covariances, taken in column blocks); above, the family's random-feature basis Phi stands
// in for K (cov(q) = s2 / v (A_x Phi Phi^T A_x^T + ...), v the basis's mean variance at the points), whose
// sampling error moved single rows by up to ~10%: with the basis's 400 features, a Gaussian field of 0.2 px
// RMS at 384 px on a 1080p camera 3 m from the screen, straight on, had the camera's lateral position's row
// 8% below the exact one and the radius's 10% above (docs/bench/validity_bench.txt, twenty-fourth session).
QuantityVariance FieldVariance(const Setup& setup, const Linearization& lin, const PixelLockingCorrection& correction,
                               const UncertaintyBudget::FieldComponent& component) {
  const int n = static_cast<int>(lin.obs.size());
  const bool ring = component.family == UncertaintyBudget::FieldFamily::kRing;
  if (n > (ring ? kExactRingFieldPoints : kExactFieldPoints)) {
    // G_f Phi = sel (J^T J)^+ (J_f^T Phi), J_f^T Phi photo by photo (a photo's rows of J touch its pose and
    // the shared columns only): a quarter of the products of the dense G_f Phi at ten photos.
    double phi_squared = 0;
    RowMajor phi;
    std::array<Eigen::MatrixXd, 2> m_phi;
    const std::array<RowMajor, 2> jtp =
        JacobianTimesBasis(lin, PhotoBlocks(setup, lin), MisfitComponentFeatures(component, *setup.options),
                           &phi, &phi_squared, correction.ok ? &correction.solve : nullptr, &m_phi);
    // The corrected q answers the field through G - G S M (PixelLockingCorrection::Response).
    Eigen::MatrixXd mx = lin.sel_pinv * jtp[0], my = lin.sel_pinv * jtp[1];
    if (correction.ok) mx -= correction.gs * m_phi[0], my -= correction.gs * m_phi[1];
    const double variance = phi_squared / n;
    return QuantityVariance::FromCovariance(
        component.variance_px2 / variance * (mx * mx.transpose() + my * my.transpose()), setup.photos);
  }
  const long q = lin.sel_pinv.rows();
  const std::vector<Eigen::Vector2d> points = DetectedPoints(setup, lin);
  // A = [A_x; A_y], 2q x n: A_f's column i is q's response to a unit shift of detection i in coordinate f.
  Eigen::MatrixXd a(2 * q, n);
  for (int f = 0; f < 2; ++f) a.middleRows(f * q, q) = FieldResponse(lin, correction, f, q);
  // A K in column blocks of K (n x 256 at a time; the candidates' budgets may already run in parallel).
  constexpr long kBlock = 256;
  Eigen::MatrixXd ak(2 * q, n), k;
  for (long j0 = 0; j0 < n; j0 += kBlock) {
    const long m = std::min<long>(kBlock, n - j0);
    k.resize(n, m);
    for (long j = 0; j < m; ++j) {
      const Eigen::Vector2d& pj = points[static_cast<size_t>(j0 + j)];
      for (long i = 0; i < n; ++i)
        k(i, j) = MisfitComponentCovariance(component, (points[static_cast<size_t>(i)] - pj).norm());
    }
    ak.middleCols(j0, m).noalias() = a * k;
  }
  const Eigen::MatrixXd cov =
      ak.topRows(q) * a.topRows(q).transpose() + ak.bottomRows(q) * a.bottomRows(q).transpose();
  return QuantityVariance::FromCovariance(0.5 * (cov + cov.transpose()), setup.photos);
}

std::vector<std::vector<double>> StatedFieldDraws(const Setup& setup, const Linearization& lin,
                                                  const PixelLockingCorrection& correction,
                                                  const NormalisedField& field, double curvature_per_mm) {
  const long n = static_cast<long>(lin.obs.size());
  if (!field.ok || setup.photos < 1 || lin.sel_pinv.rows() < 4) return {};
  // Weights of k and the first camera's centre-frame position (q's rows 0-3) and of its axis-frame z,
  // c_z - 1/k: d = dc_z + dk / k^2; per coordinate, the response A_f of FieldVariance's exact path.
  std::array<Eigen::MatrixXd, 2> weights;
  for (int f = 0; f < 2; ++f) {
    const Eigen::MatrixXd a = FieldResponse(lin, correction, f, 4);
    Eigen::MatrixXd& w = weights[static_cast<size_t>(f)];
    w.resize(kStatedFieldQuantities, n);
    w.topRows(4) = a;
    w.row(4) = curvature_per_mm != 0 && std::isfinite(curvature_per_mm)
                   ? Eigen::MatrixXd(a.row(3) + a.row(0) / (curvature_per_mm * curvature_per_mm))
                   : Eigen::MatrixXd(a.row(3));
  }
  Eigen::VectorXd sd;
  const Eigen::MatrixXd draws = field.Respond(DetectedPoints(setup, lin), weights, &sd);
  // Each row's magnitudes over its unscaled field's standard deviation, sorted, as the means of groups of
  // consecutive ones (kStatedFieldDraws / kStatedFieldGroups each): what the coverage factor averages over.
  std::vector<std::vector<double>> out(kStatedFieldQuantities);
  for (long r = 0; r < kStatedFieldQuantities; ++r) {
    if (!(sd[r] > 0)) return {};
    std::vector<double> x(static_cast<size_t>(draws.cols()));
    for (long i = 0; i < draws.cols(); ++i) x[static_cast<size_t>(i)] = std::abs(draws(r, i)) / sd[r];
    std::sort(x.begin(), x.end());
    const size_t per = x.size() / kStatedFieldGroups;
    for (size_t g = 0; g < kStatedFieldGroups; ++g) {
      double sum = 0;
      for (size_t i = g * per; i < (g + 1) * per; ++i) sum += x[i];
      out[static_cast<size_t>(r)].push_back(sum / static_cast<double>(per));
    }
  }
  return out;
}

// The lens model misfit's RMS, measured from the residuals without the pixel-locking signature (as
// MeasureMisfitCorrelation's; UncertaintyBudget::misfit_*). Each detection is paired
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
  const std::vector<std::pair<int, int>> pairs = NeighbourPairs(setup, lin);
  if (pairs.size() < 8) return;
  const double np = static_cast<double>(pairs.size());
  double stat = 0, nu = 0;
  const Eigen::MatrixXd j_pinv = JTimes(lin, lin.normal_pinv);  // one product instead of one per pair
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
  const Eigen::MatrixXd rx = dx - JTimes(lin, lin.normal_pinv * JtTimes(lin, dx));
  const Eigen::MatrixXd ry = dy - JTimes(lin, lin.normal_pinv * JtTimes(lin, dy));
  const Eigen::MatrixXd gram = basis.transpose() * basis;
  {
    Eigen::MatrixXd projected_basis(2 * n, 2 * terms);
    projected_basis << rx, ry;
    const Eigen::VectorXd r = Stacked(residual);
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
}

// The misfit field's components (EstimateMisfitCorrelation) from one model's residuals without the pixel-locking
// signature (ModelWork::signature; left in, the signature, a beat across a regular board, would be measured again
// here as a correlated field: counted twice; subtracting its unprojected shape instead would put back the part the
// refit absorbed, a smooth field with the wrong sign: tried, the row grew), each observation paired with its
// nearest neighbour as in EstimateMisfit. Called once per fit, on the chosen model (CompleteFits in screen_fit.cc);
// nothing when EstimateMisfit found the family invisible.
void MeasureMisfitCorrelation(const Setup& setup, const Linearization& lin,
                              const std::vector<Eigen::Vector2d>& residual, double sigma_px,
                              UncertaintyBudget* bud) {
  if (lin.obs.size() < 8 || residual.size() != lin.obs.size() || !(bud->misfit_kappa > 1e-6)) return;
  EstimateMisfitCorrelation(setup, lin, residual, sigma_px, NeighbourPairs(setup, lin), bud);
}

}  // namespace curvecheck::screen_fit_internal
