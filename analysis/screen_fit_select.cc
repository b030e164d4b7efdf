// Model selection among the candidate screen models (analysis/screen_fit_internal.h): the held-out error, the
// lens model misfit as a correlated error in the comparison, and the choice (FitOptions::bic_margin,
// heldout_tolerance).
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "analysis/screen_fit_internal.h"

namespace curvecheck::screen_fit_internal {
namespace {

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

// The fold of each feature (by its index among the ids): a fixed shuffle, the same folds for every model.
std::vector<int> FoldOfFeature(size_t features, int folds) {
  std::vector<int> order(features);
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(20261122);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<int> fold_of(order.size());
  for (size_t i = 0; i < order.size(); ++i) fold_of[static_cast<size_t>(order[i])] = static_cast<int>(i) % folds;
  return fold_of;
}

// The fold of each feature as contiguous strips across u: the features sorted by their u (the display's
// horizontal coordinate, the same in every photo), strip f holding the f-th of `folds` equal shares.
std::vector<int> StripOfFeature(const Setup& setup, int folds) {
  std::vector<double> u(setup.feature_ids.size(), kNaN);
  for (const Obs& o : setup.obs) u[static_cast<size_t>(o.feature)] = o.uv.x();
  std::vector<int> order(u.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return u[static_cast<size_t>(a)] < u[static_cast<size_t>(b)]; });
  std::vector<int> fold_of(order.size());
  for (size_t i = 0; i < order.size(); ++i) {
    fold_of[static_cast<size_t>(order[i])] = static_cast<int>(i * static_cast<size_t>(folds) / order.size());
  }
  return fold_of;
}

// Per photo, the observations a fold's refit keeps (inliers outside the fold). A photo left with fewer than 6 has
// no determined pose, and its held-out residuals are not counted.
std::vector<int> KeptPerPhoto(const Setup& setup, const std::vector<bool>& inlier, const std::vector<int>& fold_of,
                              int fold) {
  std::vector<int> per_photo(static_cast<size_t>(setup.photos), 0);
  for (size_t i = 0; i < setup.obs.size(); ++i) {
    if (inlier[i] && fold_of[static_cast<size_t>(setup.obs[i].feature)] != fold) {
      ++per_photo[static_cast<size_t>(setup.obs[i].photo)];
    }
  }
  return per_photo;
}

// The folds refitted by one Gauss-Newton step from the full solution (FitOptions::heldout_exact_refit false).
// With e the Ceres residuals and J their Jacobian at the full fit (Linearization: N = J^T J and g = J^T e over
// every row), the fold's rows (J_k, e_k) taken out leave N_k = N - J_k^T J_k and g_k = g - J_k^T e_k; the step is
// d = -N_k^+ g_k and the fold's predicted residuals e_k + J_k d. N_k's pseudo-inverse is taken on the
// column-equilibrated matrix (units differ by 1e6), directions below 1e-12 of the largest eigenvalue dropped, as
// the linearization does.
double HeldOutLinearized(const Setup& setup, const Linearization& lin, const std::vector<bool>& inlier,
                         const std::vector<int>& fold_of, const std::vector<Eigen::Vector2d>& residual) {
  const int folds = setup.options->heldout_folds;
  const long t = lin.normal.rows();
  double sum = 0;
  int count = 0;
  for (int f = 0; f < folds; ++f) {
    std::vector<size_t> rows;  // indices into lin.obs
    for (size_t m = 0; m < lin.obs.size(); ++m) {
      if (fold_of[static_cast<size_t>(setup.obs[lin.obs[m]].feature)] == f) rows.push_back(m);
    }
    if (rows.empty()) continue;
    const long nk = static_cast<long>(2 * rows.size());
    Eigen::MatrixXd jk(nk, t);
    Eigen::VectorXd ek(nk);
    for (size_t q = 0; q < rows.size(); ++q) {
      const long row = static_cast<long>(2 * rows[q]), out = static_cast<long>(2 * q);
      jk.middleRows(out, 2) = lin.j_obs.middleRows(row, 2);
      ek.segment<2>(out) = -residual[rows[q]];  // residual_px is detected - predicted; Ceres's is the opposite
    }
    const Eigen::MatrixXd nk_normal = lin.normal - jk.transpose() * jk;
    const Eigen::VectorXd gk = lin.gradient - jk.transpose() * ek;
    Eigen::VectorXd scale = nk_normal.diagonal().cwiseMax(0).cwiseSqrt();
    for (long c = 0; c < t; ++c) scale[c] = scale[c] > 0 ? 1 / scale[c] : 0;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scale.asDiagonal() * nk_normal * scale.asDiagonal());
    if (eig.info() != Eigen::Success) return kNaN;
    const Eigen::VectorXd& ev = eig.eigenvalues();
    const double cut = 1e-12 * std::max(ev.maxCoeff(), 1e-300);
    Eigen::VectorXd coordinates = eig.eigenvectors().transpose() * (scale.asDiagonal() * gk);
    for (long c = 0; c < t; ++c) coordinates[c] = ev[c] > cut ? coordinates[c] / ev[c] : 0;
    const Eigen::VectorXd step = -(scale.asDiagonal() * (eig.eigenvectors() * coordinates));
    const Eigen::VectorXd predicted = ek + jk * step;
    const std::vector<int> per_photo = KeptPerPhoto(setup, inlier, fold_of, f);
    for (size_t q = 0; q < rows.size(); ++q) {
      const Eigen::Vector2d e = predicted.segment<2>(static_cast<long>(2 * q));
      if (per_photo[static_cast<size_t>(setup.obs[lin.obs[rows[q]]].photo)] < 6 || !e.allFinite()) continue;
      sum += e.squaredNorm();
      ++count;
    }
  }
  return count > 0 ? std::sqrt(sum / count) : kNaN;
}

}  // namespace

// k-fold over feature ids: refit without each fold (from the full solution), predict the fold.
double HeldOut(const Setup& setup, const ModelWork& w, const std::vector<bool>& inlier, const ModelFit& fit,
               bool strips) {
  const int folds = setup.options->heldout_folds;
  if (folds < 2) return kNaN;
  const std::vector<int> fold_of =
      strips ? StripOfFeature(setup, folds) : FoldOfFeature(setup.feature_ids.size(), folds);
  if (!setup.options->heldout_exact_refit && w.lin && w.lin->normal.size() > 0 && !fit.residual_px.empty()) {
    return HeldOutLinearized(setup, *w.lin, inlier, fold_of, LinearizedResiduals(setup, *w.lin, fit));
  }
  double sum = 0;
  int count = 0;
  for (int f = 0; f < folds; ++f) {
    std::vector<bool> active(setup.obs.size());
    for (size_t i = 0; i < setup.obs.size(); ++i) {
      active[i] = inlier[i] && fold_of[static_cast<size_t>(setup.obs[i].feature)] != f;
    }
    const std::vector<int> per_photo = KeptPerPhoto(setup, inlier, fold_of, f);
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
  // The veto: a candidate whose strip error exceeds a simpler adequate candidate's by more than the tolerance
  // (NaN errors veto nothing). The simplest adequate candidate is never vetoed, so the pool stays non-empty.
  std::string vetoed;
  for (size_t i = 0; i < c.size(); ++i) {
    result->candidates[i].vetoed = false;
    if (!c[i].converged || !std::isfinite(c[i].heldout_strips_px)) continue;
    for (size_t j = 0; j < i; ++j) {
      if (!c[j].converged || !c[j].adequate || !std::isfinite(c[j].heldout_strips_px)) continue;
      if (c[i].heldout_strips_px > c[j].heldout_strips_px * (1 + options.heldout_tolerance)) {
        result->candidates[i].vetoed = true;
        vetoed += fmt::format("{}{} (strip error {:.4f} px against {}'s {:.4f} px)", vetoed.empty() ? "" : ", ",
                              c[i].model, c[i].heldout_strips_px, c[j].model, c[j].heldout_strips_px);
        break;
      }
    }
  }
  const auto in_pool = [&](size_t i) {
    return c[i].converged && (c[i].adequate || !any_adequate) && !c[i].vetoed;
  };
  const std::string pool_note =
      (inadequate.empty() ? std::string()
       : any_adequate     ? "; left out as inadequate: " + inadequate
                          : "; no candidate is adequate") +
      (vetoed.empty() ? std::string()
                      : "; left out as predicting strips of the screen left out of the fit worse than a simpler "
                        "model (a shape the rest of the screen does not carry over to them: correlated detection "
                        "errors, not the screen): " +
                            vetoed) +
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

}  // namespace curvecheck::screen_fit_internal

namespace curvecheck {

using namespace screen_fit_internal;  // NOLINT: this file implements screen_fit.h with them

void ChooseModel(const FitOptions& options, ScreenFitResult* result) { Choose(options, result); }

}  // namespace curvecheck
