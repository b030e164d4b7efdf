// The detector-systematic row's smooth bound b (analysis/screen_fit_internal.h SmoothBound): the detector's
// scatter about the fit less the part that cannot add up to a smooth field, either the part that lattice
// neighbours do not share (WhiteScatterPx, the residuals' second differences) or the corners' random part
// that the detection measured (SmoothBoundPx); the budget (screen_fit_budget.cc) scales its Legendre fields
// by b. On the same lattice, the test of the detection-noise row's independence (NoiseIndependenceCheck).
#include <Eigen/Core>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"

namespace curvecheck::screen_fit_internal {

constexpr std::array<double, 3> kStencil = {1, -2, 1};


SmoothBound SmoothBoundFromPart(double scatter_px, double part_px, double u_difference_px2) {
  SmoothBound b;
  b.difference_px2 = std::max(0.0, scatter_px * scatter_px - part_px * part_px);
  b.margin_px2 = 1.645 * u_difference_px2;
  b.bound_px = std::min(scatter_px, std::sqrt(b.difference_px2 + b.margin_px2));
  return b;
}

SmoothBound SmoothBoundPx(double scatter_px, double scatter_dof, double random_px, double random_u_px2) {
  const double s2 = scatter_px * scatter_px;
  const double u2 = (scatter_dof > 0 ? 2 * s2 * s2 / scatter_dof : 0) + random_u_px2 * random_u_px2;
  return SmoothBoundFromPart(scatter_px, random_px, std::sqrt(u2));
}

namespace {

// The lattice triples among the active observations lin.obs (Setup::obs indices), and their overlap Q: found once
// per set of observations (Setup::cache), since every candidate model usually fits the same ones.
std::shared_ptr<const Setup::LatticeTriples> FindLatticeTriples(const Setup& setup, const Linearization& lin) {
  Setup::Cache& cache = *setup.cache;
  const std::lock_guard<std::mutex> lock(cache.mutex);  // the others wait for the same triples
  for (const auto& found : cache.triples) {
    if (found->obs == lin.obs) return found;
  }
  auto out = std::make_shared<Setup::LatticeTriples>();
  out->obs = lin.obs;
  std::vector<std::vector<size_t>> in_photo(static_cast<size_t>(setup.photos));
  for (const size_t a : lin.obs) in_photo[static_cast<size_t>(setup.obs[a].photo)].push_back(a);
  const auto at = [&](size_t a) {  // on the screen, mm (the display's pixels are square)
    return Eigen::Vector2d(setup.obs[a].s_mm, setup.obs[a].y_mm);
  };
  std::vector<std::pair<double, size_t>> near;
  std::vector<Eigen::Vector2d> done;  // the directions (either sense) that gave i a triple
  for (const std::vector<size_t>& photo : in_photo) {
    for (const size_t i : photo) {
      near.clear();
      for (const size_t j : photo) {
        if (j != i) near.emplace_back((at(j) - at(i)).squaredNorm(), j);
      }
      const size_t keep = std::min(near.size(), kWhiteNeighbours);
      std::partial_sort(near.begin(), near.begin() + static_cast<long>(keep), near.end());
      near.resize(keep);
      // In each direction the shortest step d whose mirror -d was fitted too (a checkerboard's next corner on either
      // side; for tags, a cell-wide gap between tags of several cells, the same corner of the next tags), up to 1.5
      // times i's shortest such step: rows, columns and diagonals of a square lattice, not its longer chords.
      const auto same_line = [](const Eigen::Vector2d& d, const Eigen::Vector2d& e) {
        return std::abs(d.x() * e.y() - d.y() * e.x()) < 0.1 * d.norm() * e.norm();
      };
      done.clear();
      for (size_t x = 0; x < near.size(); ++x) {
        const Eigen::Vector2d d = at(near[x].second) - at(i);
        if (!(d.squaredNorm() > 0)) continue;
        if (!done.empty() && d.squaredNorm() > 1.5 * 1.5 * done.front().squaredNorm()) break;
        if (std::any_of(done.begin(), done.end(), [&](const Eigen::Vector2d& e) { return same_line(d, e); })) {
          continue;
        }
        for (size_t y = 0; y < near.size(); ++y) {
          if (y != x && (at(near[y].second) - at(i) + d).norm() <= 0.1 * d.norm()) {
            out->triples.push_back({near[x].second, i, near[y].second});
            done.push_back(d);
            break;
          }
        }
      }
    }
  }
  // Q = sum over pairs of triples (itself included) of (a_t . a_t')^2, per coordinate.
  // per feature (Setup::obs index): (triple, its coefficient there)
  std::vector<std::vector<std::pair<size_t, double>>> member(setup.obs.size());
  for (size_t t = 0; t < out->triples.size(); ++t) {
    for (size_t m = 0; m < 3; ++m) member[out->triples[t][m]].emplace_back(t, kStencil[m]);
  }
  double q = 0;
  std::vector<std::pair<size_t, double>> dots;
  for (const std::array<size_t, 3>& triple : out->triples) {
    dots.clear();
    for (size_t m = 0; m < 3; ++m) {
      for (const auto& [other, c] : member[triple[m]]) dots.emplace_back(other, kStencil[m] * c);
    }
    std::sort(dots.begin(), dots.end());
    for (size_t x = 0; x < dots.size();) {
      double dot = 0;
      size_t y = x;
      for (; y < dots.size() && dots[y].first == dots[x].first; ++y) dot += dots[y].second;
      q += dot * dot;
      x = y;
    }
  }
  out->overlap = q;
  cache.triples.push_back(out);
  return out;
}

}  // namespace

NeighbourScatter WhiteScatterPx(const Setup& setup, const Linearization& lin,
                                const std::vector<Eigen::Vector2d>& residuals, double scatter_px,
                                double scatter_dof, const PixelLockingSignature* removed) {
  NeighbourScatter out;
  const size_t n = lin.obs.size();
  if (residuals.size() != n || !(scatter_dof > 0) || !std::isfinite(scatter_px)) return out;
  const std::shared_ptr<const Setup::LatticeTriples> found = FindLatticeTriples(setup, lin);
  const std::vector<std::array<size_t, 3>>& triples = found->triples;
  if (triples.size() < static_cast<size_t>(kMinWhiteTriples)) return out;
  std::vector<size_t> column(setup.obs.size());  // Setup::obs index -> its position in lin.obs
  for (size_t a = 0; a < n; ++a) column[lin.obs[a]] = a;
  const bool signature = removed != nullptr && removed->ok && removed->projected.rows() == 2 * static_cast<long>(n) &&
                         removed->noise_px > 0;
  // X = D P S, the second differences of the signature's projected shapes (2 rows per triple).
  Eigen::MatrixXd x(signature ? 2 * static_cast<long>(triples.size()) : 0, signature ? removed->projected.cols() : 0);
  double sum2 = 0;
  for (size_t t = 0; t < triples.size(); ++t) {
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    for (size_t m = 0; m < 3; ++m) d += kStencil[m] * residuals[column[triples[t][m]]];
    sum2 += d.squaredNorm();
    if (!signature) continue;
    for (long c = 0; c < 2; ++c) {
      x.row(2 * static_cast<long>(t) + c).setZero();
      for (size_t m = 0; m < 3; ++m) {
        x.row(2 * static_cast<long>(t) + c) +=
            kStencil[m] * removed->projected.row(2 * static_cast<long>(column[triples[t][m]]) + c);
      }
    }
  }
  const double count = static_cast<double>(triples.size());
  // White noise e's second differences after the signature's removal, D (I - Q) e with Q = P S K (P S)^T
  // (K = (A + lambda I)^-1 = C / s^2): E |D (I - Q) e|^2 = sigma^2 (tr D D^T - 2 tr D Q D^T + |D Q|^2), tr D D^T =
  // 12 T, tr D Q D^T = tr X K X^T, |D Q|^2 = tr X K A K X^T. The fit's own columns are smooth and take next to
  // nothing of a second difference.
  double kept = 1;
  if (signature) {
    const Eigen::MatrixXd k = removed->covariance / (removed->noise_px * removed->noise_px);
    const Eigen::MatrixXd xk = x * k;
    kept = 1 - (2 * xk.cwiseProduct(x).sum() - (xk * removed->normal).cwiseProduct(xk).sum()) / (12 * count);
  }
  if (!(kept > 0)) return out;
  out.triples = static_cast<int>(triples.size());
  out.white_px = std::sqrt(sum2 / (12 * count * kept));
  // tr(M^2) with s^2's own term exact (var s^2 = 2 sigma^4 / dof): 1 / dof - 2 / dof + 2 Q / (12 T)^2.
  const double trace = std::max(0.0, 2 * found->overlap / (144 * count * count) - 1 / scatter_dof);
  const double s2 = scatter_px * scatter_px;
  out.u_difference_px2 = std::sqrt(2 * trace) * s2;
  return out;
}

UncertaintyBudget::NoiseIndependence NoiseIndependenceCheck(const Setup& setup, const Linearization& lin,
                                                            const std::vector<Eigen::Vector2d>& residuals) {
  UncertaintyBudget::NoiseIndependence out;
  const size_t n = lin.obs.size();
  if (residuals.size() != n || lin.j_obs.rows() != 2 * static_cast<long>(n) ||
      lin.normal_pinv.rows() != lin.j_obs.cols()) {
    return out;
  }
  const std::shared_ptr<const Setup::LatticeTriples> found = FindLatticeTriples(setup, lin);
  if (found->triples.size() < static_cast<size_t>(kMinWhiteTriples)) return out;
  std::vector<size_t> column(setup.obs.size());  // Setup::obs index -> its position in lin.obs
  for (size_t a = 0; a < n; ++a) column[lin.obs[a]] = a;
  // The neighbour pairs (positions in lin.obs) of the triples' steps, once each, along the screen's rows (0) or
  // columns (1); diagonal steps are left out.
  std::vector<std::pair<size_t, size_t>> edges;
  for (const std::array<size_t, 3>& triple : found->triples) {
    for (size_t m = 0; m < 2; ++m) {
      const size_t a = column[triple[m]], b = column[triple[m + 1]];
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  // The hat matrix's entries H_ab = J_a (J^T J)^+ J_b^T through JN = J (J^T J)^+.
  const Eigen::MatrixXd jn = lin.j_obs * lin.normal_pinv;
  const auto hat = [&](long row_a, long row_b) { return jn.row(row_a).dot(lin.j_obs.row(row_b)); };
  Eigen::Matrix2d product = Eigen::Matrix2d::Zero(), hat_sum = Eigen::Matrix2d::Zero();
  for (const auto& [a, b] : edges) {
    const Obs& oa = setup.obs[lin.obs[a]];
    const Obs& ob = setup.obs[lin.obs[b]];
    const double ds = std::abs(ob.s_mm - oa.s_mm), dy = std::abs(ob.y_mm - oa.y_mm), d = std::hypot(ds, dy);
    const int direction = dy < 0.25 * d ? 0 : ds < 0.25 * d ? 1 : -1;
    if (direction < 0) continue;
    ++out.pairs[static_cast<size_t>(direction)];
    for (long c = 0; c < 2; ++c) {
      product(c, direction) += residuals[a][c] * residuals[b][c];
      hat_sum(c, direction) += hat(2 * static_cast<long>(a) + c, 2 * static_cast<long>(b) + c);
    }
  }
  // Per coordinate: the mean square and its expectation's factor under independence, mean 1 - H_ii.
  Eigen::Vector2d sum_sq = Eigen::Vector2d::Zero(), sum_keep = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < n; ++i) {
    for (long c = 0; c < 2; ++c) {
      const long r = 2 * static_cast<long>(i) + c;
      sum_sq[c] += residuals[i][c] * residuals[i][c];
      sum_keep[c] += 1 - hat(r, r);
    }
  }
  for (long d = 0; d < 2; ++d) {
    const int count = out.pairs[static_cast<size_t>(d)];
    for (long c = 0; c < 2; ++c) {
      if (count < kMinWhiteTriples || !(sum_sq[c] > 0) || !(sum_keep[c] > 0)) continue;
      out.correlation(c, d) = (product(c, d) / count) / (sum_sq[c] / static_cast<double>(n));
      out.null_correlation(c, d) = -(hat_sum(c, d) / count) / (sum_keep[c] / static_cast<double>(n));
      out.z(c, d) = (out.correlation(c, d) - out.null_correlation(c, d)) * std::sqrt(static_cast<double>(count));
      if (std::abs(out.z(c, d)) >= UncertaintyBudget::kNoiseIndependenceZ) out.independent = false;
    }
  }
  out.tested = out.z.array().isFinite().any();
  if (!out.tested) {
    out.independent = true;
    return out;
  }
  const auto entry = [](double r, double z) {
    return std::isfinite(z) ? fmt::format("{:+.2f} (z {:+.1f})", r, z) : std::string("not measured");
  };
  const Eigen::Array22d null = out.null_correlation.array();
  out.summary = fmt::format(
      "tested on {} row and {} column pairs of lattice neighbours on the screen, their residuals' correlation along "
      "the screen's rows x {}, y {}, along its columns x {}, y {} (z against independence, under which the fit makes "
      "it {:+.3f} on average); {}",
      out.pairs[0], out.pairs[1], entry(out.correlation(0, 0), out.z(0, 0)), entry(out.correlation(1, 0), out.z(1, 0)),
      entry(out.correlation(0, 1), out.z(0, 1)), entry(out.correlation(1, 1), out.z(1, 1)),
      null.isFinite().select(null, 0.0).sum() / static_cast<double>(std::max<long>(1, null.isFinite().count())),
      out.independent
          ? fmt::format("consistent with independence (every |z| < {:g})", UncertaintyBudget::kNoiseIndependenceZ)
          : fmt::format("not independent (|z| >= {:g}): where neighbours' errors alternate (negative), this row "
                        "overstates what they do to a smooth quantity, and where they are shared (positive) it "
                        "understates it, the part that the detector-systematic and lens-model-misfit rows are to "
                        "hold; the validity bench measures the intervals' coverage with such errors "
                        "(docs/bench/validity_bench.txt)",
                        UncertaintyBudget::kNoiseIndependenceZ));
  return out;
}

}  // namespace curvecheck::screen_fit_internal
