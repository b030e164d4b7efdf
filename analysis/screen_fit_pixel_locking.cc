// The detector's pixel-locking signature measured through the screen fit (analysis/screen_fit_internal.h): its
// shapes at the fit's predictions, its coefficients fitted on their refit projections, the independent noise that
// remains once it is removed, and the correction of the quantities of interest for it. The budget
// (screen_fit_budget.cc) applies the correction and propagates its uncertainty; the lens-model-misfit statistics
// (screen_fit_misfit.cc) take the residuals without it.
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"
#include "core/error.h"
#include "pattern/feature_id.h"

namespace curvecheck::screen_fit_internal {

Eigen::VectorXd Stacked(const std::vector<Eigen::Vector2d>& residual) {
  Eigen::VectorXd r(2 * static_cast<long>(residual.size()));
  for (size_t i = 0; i < residual.size(); ++i) r.segment<2>(2 * static_cast<long>(i)) = residual[i];
  return r;
}

TagCorners CompleteTags(const Setup& setup, const Linearization& lin) {
  std::map<std::pair<int, int>, std::array<int, 4>> tags;
  for (size_t i = 0; i < lin.obs.size(); ++i) {
    const Obs& o = setup.obs[lin.obs[i]];
    const std::string& id = setup.feature_ids[static_cast<size_t>(o.feature)];
    int tag = -1, corner = -1;
    char end = 0;
    if (id.size() < 4 || id[0] != 't' || std::sscanf(id.c_str() + 1, "%d.%d%c", &tag, &corner, &end) != 2 ||
        corner < 0 || corner > 3) {
      continue;
    }
    auto [it, added] = tags.try_emplace({o.photo, tag}, std::array<int, 4>{-1, -1, -1, -1});
    it->second[static_cast<size_t>(corner)] = static_cast<int>(i);
  }
  std::vector<std::array<int, 4>> complete;
  for (const auto& [key, corners] : tags) {
    if (std::all_of(corners.begin(), corners.end(), [](int c) { return c >= 0; })) complete.push_back(corners);
  }
  if (complete.size() < static_cast<size_t>(kMinBorderTags)) complete.clear();
  return complete;
}

std::vector<int> CheckerboardPolarity(const Setup& setup, const Linearization& lin) {
  const size_t n = lin.obs.size();
  std::vector<long> k(n, -1);  // the board index of each checkerboard corner
  int corners = 0;
  for (size_t i = 0; i < n; ++i) {
    const std::optional<long> v =
        CornerIndexOfId(setup.feature_ids[static_cast<size_t>(setup.obs[lin.obs[i]].feature)]);
    if (v) {
      k[i] = *v;
      ++corners;
    }
  }
  if (corners < kMinPolarityCorners) return {};
  std::map<long, int> strides;
  int counted = 0;
  for (size_t i = 0; i < n; ++i) {
    if (k[i] < 0) continue;
    const Obs& a = setup.obs[lin.obs[i]];
    double nearest = std::numeric_limits<double>::infinity();
    long stride = 0;
    for (size_t j = 0; j < n; ++j) {
      const Obs& b = setup.obs[lin.obs[j]];
      const long dk = std::labs(k[j] - k[i]);
      if (k[j] < 0 || dk <= 1 || b.photo != a.photo) continue;
      const double d = std::hypot(a.s_mm - b.s_mm, a.y_mm - b.y_mm);
      if (d < nearest) {
        nearest = d;
        stride = dk;
      }
    }
    if (stride > 1) {
      ++strides[stride];
      ++counted;
    }
  }
  const auto most = std::max_element(strides.begin(), strides.end(),
                                     [](const auto& x, const auto& y) { return x.second < y.second; });
  if (most == strides.end() || 2 * most->second < counted) return {};
  const long stride = most->first;
  std::vector<int> polarity(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (k[i] >= 0) polarity[i] = (k[i] / stride + k[i] % stride) % 2 == 0 ? 1 : -1;
  }
  return polarity;
}

SignatureLayout SignatureLayoutOf(const Setup& setup, const Linearization& lin) {
  Setup::Cache& cache = *setup.cache;
  const std::lock_guard<std::mutex> lock(cache.mutex);  // the others wait for the same layout
  for (const auto& [obs, found] : cache.layouts) {
    if (obs == lin.obs) return *found;
  }
  auto layout = std::make_shared<SignatureLayout>();
  layout->tags = CompleteTags(setup, lin);
  layout->polarity = CheckerboardPolarity(setup, lin);
  cache.layouts.emplace_back(lin.obs, layout);
  return *layout;
}

// The signature's shapes at the active observations (2n x columns, rows interleaved x, y).
// Pixel-locking (the first 4 kPixelLockingTerms columns): columns PixelLockingColumn(c, t) and the next hold sin and
// cos of 2 pi x the phase of coordinate c in period kPixelLockingPeriods[t] on that coordinate's rows, zero
// elsewhere. The phase is that of the fit's prediction (detected - residual), not of the detection: the detection's
// own noise e moves its phase by 2 pi e / T, and the shapes then correlate with the residual (-e) whatever the
// detector does (a regression on them found 0.29 +- 0.04 px in pure 0.1 px noise on a 9 x 9 patch;
// ScreenFitTest.RelativeCurvatureSigmaLimitDropsTheRadiusNumber).
// The tag border shift (SignatureLayout::kTagBorderColumns more, where kMinBorderTags tags or more have all four
// corners): a detector that places a tag's black border's edges a distance d outward of where they are (blur, the
// sensor's tone, the border one cell wide) moves each corner by d along both edges' outward normals, sqrt(2) d along
// the tag's diagonal for a square; column kTagBorderX holds sqrt(2) u_x on the x rows of tag corners and
// kTagBorderX + 1 sqrt(2) u_y on their y rows, u the unit vector from the tag's centre (its four predictions' mean) to
// the corner's prediction: the coefficients are the border shifts in x and y, px, positive outward, common to every
// tag and photo. The pose cannot take it up (a tag's centre does not move), but with the tags' size changing across
// the photo it reads as curvature: 0.57 px inward per coordinate on 16 x 4 tags from 3 m at half resolution (the
// synthetic camera's realistic chain) moved the radius by -8.3 mm, 1.1 of its sigma (2026-12-07).
Eigen::MatrixXd PixelLockingShapes(const Setup& setup, const Linearization& lin, const Eigen::VectorXd& residual,
                                   const SignatureLayout& layout) {
  constexpr double kTwoPi = 6.283185307179586;
  const int n = static_cast<int>(lin.obs.size());
  const long columns = layout.Columns();
  const bool polarity = !layout.polarity.empty();
  Eigen::MatrixXd shapes = Eigen::MatrixXd::Zero(2 * n, columns);
  const auto predicted = [&](int i) {
    Eigen::Vector2d q = setup.obs[lin.obs[static_cast<size_t>(i)]].detected;
    if (residual.size() == 2 * n && residual.segment<2>(2 * i).allFinite()) q -= residual.segment<2>(2 * i);
    return q;
  };
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d q = predicted(i);
    for (int c = 0; c < 2; ++c) {
      for (int t = 0; t < kPixelLockingTerms; ++t) {
        const double u = q[c] / kPixelLockingPeriods[static_cast<size_t>(t)], phase = kTwoPi * (u - std::floor(u));
        shapes(2 * i + c, PixelLockingColumn(c, t)) = std::sin(phase);
        shapes(2 * i + c, PixelLockingColumn(c, t) + 1) = std::cos(phase);
      }
    }
    // The 2 px period's phases of x and y: sin, cos (the colour filter array's 2 x 2 cell).
    std::array<std::array<double, 2>, 2> f{};
    for (int c = 0; c < 2; ++c) {
      const double u = q[c] / 2, phase = kTwoPi * (u - std::floor(u));
      f[static_cast<size_t>(c)] = {std::sin(phase), std::cos(phase)};
    }
    const double p = polarity ? layout.polarity[static_cast<size_t>(i)] : 0.0;
    for (int c = 0; c < 2; ++c) {
      const long cell = layout.CellColumn(c);
      const std::array<double, 2>& other = f[static_cast<size_t>(1 - c)];
      const std::array<double, 6> cell_shapes = {other[0],         other[1],         f[0][0] * f[1][0],
                                                 f[0][0] * f[1][1], f[0][1] * f[1][0], f[0][1] * f[1][1]};
      for (long x = 0; x < 6; ++x) shapes(2 * i + c, cell + x) = cell_shapes[static_cast<size_t>(x)];
      if (p != 0) {
        const long col = layout.PolarityColumn(c);
        const std::array<double, 5> polarity_shapes = {1, f[0][0], f[0][1], f[1][0], f[1][1]};
        for (long x = 0; x < 5; ++x) shapes(2 * i + c, col + x) = p * polarity_shapes[static_cast<size_t>(x)];
      }
    }
  }
  for (const std::array<int, 4>& tag : layout.tags) {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const int i : tag) centre += predicted(i) / 4;
    for (const int i : tag) {
      const Eigen::Vector2d d = predicted(i) - centre;
      if (!(d.norm() > 0)) continue;
      const Eigen::Vector2d u = std::sqrt(2.0) * d / d.norm();
      shapes(2 * i, SignatureLayout::kTagBorderX) = u.x();
      shapes(2 * i + 1, SignatureLayout::kTagBorderX + 1) = u.y();
    }
  }
  return shapes;
}

PixelLockingSignature FitPixelLocking(const Setup& setup, const Linearization& lin,
                                      const std::vector<Eigen::Vector2d>& residual_px, int parameters) {
  PixelLockingSignature s;
  s.residual_without = residual_px;
  const int n = static_cast<int>(lin.obs.size());
  if (static_cast<int>(residual_px.size()) != n) {
    throw Error("pixel-locking estimate", "residuals and linearization differ in number", "");
  }
  s.observations = n;
  s.layout = SignatureLayoutOf(setup, lin);
  s.dof = 2 * n - parameters - static_cast<int>(s.layout.Columns());
  const Eigen::VectorXd r = Stacked(residual_px);
  if (s.dof < 2 || !r.allFinite()) return s;
  // The coefficients' prior N(0, sigma_b^2 I) (FitOptions::pixel_locking_prior_px, type B): the posterior mean and
  // covariance are those of the regression with lambda = s^2 / sigma_b^2 added to the normal matrix,
  // b = (A + lambda I)^-1 (P S)^T r, C = s^2 (A + lambda I)^-1 (A = S^T P S). Where the photos determine a
  // coefficient (A >> lambda: hundreds of observations) it is the regression's; where the fit absorbs a shape
  // (a pattern corrected for the camera's viewpoint is a regular grid in the photo: seen frontally its rows share
  // nearly one phase, and the shape is nearly a shift the pose takes up) the coefficient is bounded by the prior
  // rather than fitted to noise (amplitudes of 0.3-2.6 px +- 0.1-0.9 px and radius corrections of 15-80 mm on such
  // trials of the validity bench without it, 2026-12-05). s^2 is the regression's residual variance, found by fixed
  // point from the total.
  const double prior = setup.options->pixel_locking_prior_px;
  const bool bounded = prior > 0;  // 0: no prior
  double s2 = r.squaredNorm() / std::max(1, 2 * n - parameters);
  Eigen::LDLT<Eigen::MatrixXd> ldlt;
  Eigen::VectorXd fitted, absorbed_shift = Eigen::VectorXd::Zero(r.size());
  // The shapes' phases are those of the true positions: the fit's predictions less the part of the signature it
  // absorbed, (I - P) S b (the prediction moves by J (J^T J)^+ J^T of any bias). Taken at the predictions alone they
  // are off by up to the signature's amplitude (0.07 px of a 1 px period is 0.44 rad), and where the fit absorbs
  // most of it the correction G S b, a difference of nearly cancelling terms, follows that error: on a corrected
  // board 440 px wide from 3 m at quarter resolution, noise-free, the corrected radius missed by up to 12 mm of a
  // 36 mm shift (now 1.1 mm at most over six seeds), and with 0.03 px noise its RMS error was 2.15 of its sigma
  // (UncertaintyBudgetTest.PixelLockingCorrectionHoldsOnACorrectedBoard: now 0.96). The phases, lambda and s^2 are
  // one fixed point, iterated together until the absorbed shift moves by less than kShiftTolerancePx (a phase error
  // of 6e-4 rad in the 1 px period) and s^2 by less than 0.1%. Each pass is a projection of 8 columns and one 8 x 8
  // solve. It converges linearly: in that test 2 passes where the photos determine the signature, up to 7 where the
  // fit absorbs most of it (the absorbed shift shrinking about 4x per pass); without the prior, where coefficients
  // run off, it may stop at kMaxPasses.
  constexpr int kMaxPasses = 12;
  constexpr double kShiftTolerancePx = 1e-4;
  Eigen::MatrixXd projected;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    s.shapes = PixelLockingShapes(setup, lin, r + absorbed_shift, s.layout);
    projected = s.shapes - JTimes(lin, lin.normal_pinv * JtTimes(lin, s.shapes));
    s.normal = projected.transpose() * projected;
    const long m = s.normal.rows();
    if (!bounded && !(s.normal.diagonal().minCoeff() > 1e-9 * n)) return s;
    // The tag border shift's coefficients have their own, wider prior (kTagBorderPriorPx).
    Eigen::VectorXd lambda = Eigen::VectorXd::Constant(m, bounded ? s2 / (prior * prior) : 0.0);
    if (bounded && !s.layout.tags.empty()) {
      lambda.segment(SignatureLayout::kTagBorderX, SignatureLayout::kTagBorderColumns)
          .setConstant(s2 / (kTagBorderPriorPx * kTagBorderPriorPx));
    }
    ldlt.compute(s.normal + Eigen::MatrixXd(lambda.asDiagonal()));
    // Without the prior, two shapes nearly collinear after the refit would pass the diagonal test and give a huge
    // C and a meaningless correction.
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-10)) return s;
    s.solve = ldlt.solve(projected.transpose());
    s.coefficients = s.solve * r;
    fitted = projected * s.coefficients;
    const double s2_before = s2;
    s2 = (r - fitted).squaredNorm() / s.dof;
    const Eigen::VectorXd shift = (s.shapes - projected) * s.coefficients;
    const double moved = (shift - absorbed_shift).cwiseAbs().maxCoeff();
    absorbed_shift = shift;
    if (pass > 0 && moved < kShiftTolerancePx && std::abs(s2 - s2_before) < 1e-3 * s2) break;
  }
  s.noise_px = std::sqrt(s2);
  s.covariance = s2 * ldlt.solve(Eigen::MatrixXd::Identity(projected.cols(), projected.cols()));
  s.projected = std::move(projected);
  for (int i = 0; i < n; ++i) s.residual_without[static_cast<size_t>(i)] -= fitted.segment<2>(2 * i);
  s.ok = true;
  return s;
}

ResidualPixelLocking PixelLockingAmplitudes(const PixelLockingSignature& s) {
  ResidualPixelLocking out;
  out.observations = s.observations;
  out.amplitude_px.setConstant(std::numeric_limits<double>::quiet_NaN());
  out.sigma_px = out.amplitude_px;
  if (!s.ok) return out;
  out.noise_px = s.noise_px;
  for (int c = 0; c < 2; ++c) {
    for (int t = 0; t < kPixelLockingTerms; ++t) {
      const long col = PixelLockingColumn(c, t);
      const Eigen::Vector2d ab = s.coefficients.segment<2>(col);
      const Eigen::Matrix2d cc = s.covariance.block<2, 2>(col, col);
      const double a = ab.norm();
      out.amplitude_px(c, t) = a;
      const double rms_sigma = std::sqrt(0.5 * cc.trace());
      out.sigma_px(c, t) = a > 3 * rms_sigma ? std::sqrt((ab / a).dot(cc * (ab / a))) : rms_sigma;
    }
  }
  if (!s.layout.tags.empty()) {
    constexpr long kBorder = SignatureLayout::kTagBorderX;
    out.tag_border_shift_px = s.coefficients.segment<2>(kBorder);
    out.tag_border_shift_sigma_px = s.covariance.diagonal().segment<2>(kBorder).cwiseSqrt();
    out.tag_border_corners = static_cast<int>((s.shapes.col(kBorder).array() != 0).count());
  }
  if (!s.layout.polarity.empty()) {
    for (int c = 0; c < 2; ++c) {
      const long col = s.layout.PolarityColumn(c);
      out.polarity_px[c] = s.coefficients[col];
      out.polarity_sigma_px[c] = std::sqrt(s.covariance(col, col));
    }
    out.polarity_corners = static_cast<int>(
        std::count_if(s.layout.polarity.begin(), s.layout.polarity.end(), [](int p) { return p != 0; }));
  }
  return out;
}

// The signature moved the solution as a detection bias delta = S beta does: q by G delta (QuantityVariance). With
// beta estimated (b, covariance C), the corrected q is q - G S b, of covariance (the fit with the eight
// coefficients as nuisance parameters, by Frisch-Waugh-Lovell) the fit's own plus (G S) C (G S)^T.
PixelLockingCorrection CorrectionFor(const Linearization& lin, const PixelLockingSignature& s) {
  PixelLockingCorrection c;
  if (!s.ok) return c;
  c.gs = lin.g * s.shapes;
  c.solve = s.solve;
  c.dq = -c.gs * s.coefficients;
  c.covariance = c.gs * s.covariance * c.gs.transpose();
  c.ok = c.dq.allFinite() && c.covariance.allFinite();
  return c;
}

Eigen::MatrixXd PixelLockingCorrection::Response(const Eigen::MatrixXd& gx, const Eigen::MatrixXd& x) const {
  return ok ? Eigen::MatrixXd(gx - gs * (solve * x)) : gx;
}

Eigen::MatrixXd PixelLockingCorrection::SolveColumns(int c) const {
  return solve(Eigen::all, Eigen::seq(c, Eigen::last, 2));
}

Eigen::MatrixXd PixelLockingCorrection::Response(const Eigen::MatrixXd& gx, const Eigen::MatrixXd& field,
                                                 int c) const {
  return ok ? Eigen::MatrixXd(gx - gs * (SolveColumns(c) * field)) : gx;
}

double IndependentNoisePx(const ModelFit& fit) {
  const double n = fit.budget.pixel_locking.noise_px;
  return std::isfinite(n) && n > 0 && fit.noise_px > 0 ? n : fit.noise_px;
}

}  // namespace curvecheck::screen_fit_internal
