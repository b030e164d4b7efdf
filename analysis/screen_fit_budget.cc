// The screen fit's uncertainty budget (analysis/screen_fit.h): its data-only part (the Legendre bias fields; the
// misfit's field families are in misfit_fields.cc, the coverage factor in coverage_factor.cc, the lens covariance
// sidecar is read in intrinsics_covariance.cc, the pixel-locking signature is fitted in
// screen_fit_pixel_locking.cc, row 2's smooth bound in screen_fit_smooth_bound.cc), then the budget:
// each source propagated through the fit's linearization (screen_fit_linearize.cc; analysis/screen_fit_internal.h;
// the lens-model-misfit row's measurement is in screen_fit_misfit.cc).
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"
#include "core/error.h"

namespace curvecheck {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Legendre polynomial P_n(x) by the three-term recurrence.
double Legendre(int n, double x) {
  double p0 = 1, p1 = x;
  if (n == 0) return p0;
  for (int k = 1; k < n; ++k) {
    const double p2 = ((2 * k + 1) * x * p1 - k * p0) / (k + 1);
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

}  // namespace

Eigen::MatrixXd LegendreFieldBasis(const std::vector<Eigen::Vector2d>& points_px, int width, int height, int degree) {
  if (width < 2 || height < 2 || degree < 0) {
    throw Error("Legendre field basis", fmt::format("image {} x {} px, degree {}", width, height, degree), "");
  }
  std::vector<std::pair<int, int>> terms;
  for (int total = 0; total <= degree; ++total) {
    for (int i = total; i >= 0; --i) terms.emplace_back(i, total - i);
  }
  Eigen::MatrixXd b(static_cast<long>(points_px.size()), static_cast<long>(terms.size()));
  for (size_t r = 0; r < points_px.size(); ++r) {
    const double xs = 2 * points_px[r].x() / (width - 1) - 1, ys = 2 * points_px[r].y() / (height - 1) - 1;
    for (size_t t = 0; t < terms.size(); ++t) {
      b(static_cast<long>(r), static_cast<long>(t)) = Legendre(terms[t].first, xs) * Legendre(terms[t].second, ys);
    }
  }
  return b;
}

}  // namespace curvecheck

namespace curvecheck::screen_fit_internal {

namespace {

// The lens-model-misfit row takes a stated (calibration's) field unless the field measured from the residuals
// moves the curvature significantly more: var(k) measured above the stated one by more than this many of the
// measured variance's standard uncertainties (one-sided 5%). The larger of the two, the rule until 2026-12-06, is
// biased upward where both estimate the same lens's field; it had made up for a measurement that fell short by
// construction (EstimatedCovarianceWeight).
constexpr double kMisfitExcessSigmas = 1.645;

// u(k) = sqrt(var) and its standard uncertainty sd(var) / (2 sqrt(var)) (delta method), for the row's text.
double MisfitShareSd(double var, double var_sd) { return var > 0 ? var_sd / (2 * std::sqrt(var)) : 0.0; }

// Bias fields over the image of RMS `bound_px` per coordinate (Legendre polynomials of total degree <= `degree`,
// the same field in every photo), propagated through G; the covariance of q over seeded draws. The detector
// systematic's smooth part and the lens model misfit.
QuantityVariance SystematicVariance(const Setup& setup, const Linearization& lin,
                                    const PixelLockingCorrection& correction, double bound_px,
                                    const Eigen::MatrixXd& basis) {
  const FitOptions& o = *setup.options;
  const int n = static_cast<int>(lin.obs.size()), nq = static_cast<int>(lin.g.rows());
  const long terms = basis.cols();
  // A detection bias delta shifts the residual q - detected by -delta, and q by -G (-delta) = G delta.
  Eigen::MatrixXd gx(nq, n), gy(nq, n);
  for (int i = 0; i < n; ++i) gx.col(i) = lin.g.col(2 * i), gy.col(i) = lin.g.col(2 * i + 1);
  const Eigen::MatrixXd mx = correction.Response(gx * basis, basis, 0),
                        my = correction.Response(gy * basis, basis, 1);
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

// Lens calibration: dq/d(intrinsics) by central differences of the residuals at the fitted parameters (the
// linearized refit), then S Sigma S^T.
QuantityVariance LensVariance(const Setup& setup, const ModelWork& w, const Linearization& lin) {
  // d has one column per intrinsic; the corrected q answers it through PixelLockingCorrection::Response.
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
    s.col(k) = w.correction.Response(lin.g * dd, dd);
  }
  return QuantityVariance::FromCovariance(s * sigma * s.transpose(), setup.photos);
}

std::string Percent(double relative) { return fmt::format("{:.3g}%", 100 * relative); }

}  // namespace

// The active observations' detected positions, in Linearization order.
std::vector<Eigen::Vector2d> DetectedPoints(const Setup& setup, const Linearization& lin) {
  std::vector<Eigen::Vector2d> points;
  for (size_t i : lin.obs) points.push_back(setup.obs[i].detected);
  return points;
}


std::vector<Eigen::Vector2d> LinearizedResiduals(const Setup& setup, const Linearization& lin, const ModelFit& fit) {
  std::vector<Eigen::Vector2d> res;
  res.reserve(lin.obs.size());
  for (size_t i : lin.obs) {
    res.push_back(fit.residual_px[static_cast<size_t>(setup.obs[i].photo)][static_cast<size_t>(setup.obs[i].index)]);
  }
  return res;
}

// Builds the rows of one candidate's budget at its final solution (ModelWork::budget_vars, ::lin), all but the
// lens-model-misfit row's variance, which CompleteBudget adds once the model is chosen.
void Budget(const Setup& setup, ModelWork& w, int n_residuals, ModelFit* fit) {
  const FitOptions& o = *setup.options;
  UncertaintyBudget& bud = fit->budget;
  bud.coverage_probability = o.coverage_probability;
  std::vector<QuantityVariance>& vars = w.budget_vars;
  vars.clear();
  const std::optional<Linearization>& lin = w.lin;  // FitFinal's (Linearize)
  // The detector's pixel-locking signature, fitted through the fit; what the residuals hold besides it is the
  // independent noise of row 1. The quantities of interest are corrected for it (GUM 3.2.4: a recognized systematic
  // effect is corrected, and the correction's uncertainty is a component), row 2 holds that uncertainty. Carried
  // instead as an uncertainty of unknown phase (A^2 = estimate^2 + sigma^2, until 2026-12-05) it left the estimate
  // biased by the signature and counted the estimate's own noise as locking (the intervals at quarter
  // resolution covered 98-99%).
  w.signature = PixelLockingSignature{};
  if (lin) {
    std::vector<Eigen::Vector2d> res = LinearizedResiduals(setup, *lin, *fit);
    if (o.measure_pixel_locking) {
      w.signature = FitPixelLocking(setup, *lin, res, fit->parameters);
    } else {
      w.signature.residual_without = std::move(res);
    }
  }
  bud.pixel_locking = PixelLockingAmplitudes(w.signature);
  w.correction = lin ? CorrectionFor(*lin, w.signature) : PixelLockingCorrection{};
  const PixelLockingCorrection& correction = w.correction;
  if (correction.ok) {
    bud.pixel_locking_correction_curvature_per_mm = correction.dq[0];
    fit->curvature_per_mm += correction.dq[0];
    for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
      const Eigen::Vector3d d = correction.dq.segment<3>(1 + 3 * p);
      fit->cameras[static_cast<size_t>(p)].position_in_centre_mm += d;
      if (p == 0) bud.pixel_locking_correction_position_mm = d;
    }
  }
  const ResidualPixelLocking& pl = bud.pixel_locking;
  // 1. Detection noise: the covariance (Covariances, scaled by the fit's residual noise) rescaled to the noise
  // without the signature: counted in both rows, its power had stood in row 1 as independent noise as well.
  const double noise_px = IndependentNoisePx(*fit);
  const bool signature_out = noise_px != fit->noise_px;
  const int signature_columns = signature_out ? static_cast<int>(w.signature.shapes.cols()) : 0;
  const double rescale = signature_out ? (noise_px / fit->noise_px) * (noise_px / fit->noise_px) : 1.0;
  QuantityVariance noise(setup.photos);
  noise.var_k = rescale * fit->curvature_sigma_per_mm * fit->curvature_sigma_per_mm;
  for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
    noise.var_pos[static_cast<size_t>(p)] =
        rescale * fit->cameras[static_cast<size_t>(p)].position_in_centre_sigma_mm.cwiseAbs2();
    noise.cov_pos_k[static_cast<size_t>(p)] = rescale * w.position_curvature_cov[static_cast<size_t>(p)];
  }
  fit->curvature_noise_sigma_per_mm = std::sqrt(noise.var_k);
  BudgetComponent c_noise;
  c_noise.name = "detection noise";
  c_noise.type = "A";
  c_noise.dof = std::max(1, n_residuals - fit->parameters - signature_columns);
  c_noise.source = fmt::format(
      "the fit's covariance (J^T J)^-1 scaled by its residual noise without the pixel-locking signature, {:.4f} px "
      "per coordinate ({} residuals, {} parameters, {} signature coefficients; with the signature {:.4f} px)",
      noise_px, n_residuals, fit->parameters, signature_columns, fit->noise_px);
  c_noise.assumption = "independent, isotropic Gaussian detection errors; the residual scatter measures them";
  if (lin) {
    bud.noise_independence = NoiseIndependenceCheck(setup, *lin, w.signature.residual_without);
    if (bud.noise_independence.tested) c_noise.assumption += "; " + bud.noise_independence.summary;
  }
  bud.components.push_back(c_noise);
  vars.push_back(noise);

  // 2. Detector systematic: the smooth detector bias (stated, or scaled by the scatter) and the pixel-locking
  // correction's uncertainty.
  {
    NeighbourScatter white;
    if (lin && !o.smooth_bias_px && o.smooth_bound_from_neighbours) {
      white = WhiteScatterPx(setup, *lin, w.signature.residual_without, noise_px, c_noise.dof,
                             signature_out ? &w.signature : nullptr);
    }
    bud.white_scatter_px = white.white_px;
    bud.white_scatter_u_difference_px2 = white.u_difference_px2;
    bud.white_scatter_triples = white.triples;
    const std::string random_note =
        setup.random_error_samples > 0
            ? fmt::format("; the refinement's response to the photo's own noise drawn again, r = {:.4f} px ({} corner "
                          "coordinates; detect.h RefinementNoise), is a part of it",
                          setup.random_error_px, setup.random_error_samples)
            : std::string();
    if (o.smooth_bias_px) {
      bud.systematic_bound_px = *o.smooth_bias_px;
      bud.systematic_bound_reason = "the stated smooth detector bias FitOptions::smooth_bias_px (type B, not measured)";
    } else if (white.triples > 0 || setup.random_error_samples > 0) {
      // What cannot add up to a smooth field: what lattice neighbours do not share, else the measured random part.
      const bool neighbours = white.triples > 0;
      const SmoothBound sb =
          neighbours ? SmoothBoundFromPart(noise_px, white.white_px, white.u_difference_px2)
                     : SmoothBoundPx(noise_px, c_noise.dof, setup.random_error_px, setup.random_error_u_px2);
      bud.systematic_bound_px = o.smooth_bias_scatter_fraction * sb.bound_px;
      bud.systematic_bound_reason = neighbours ? fmt::format(
          "type B, scaled by measurements: {:g} x the part of the detector's scatter about the fit (without the "
          "pixel-locking signature) that neighbouring corners share, on the assumption that a detector's smooth "
          "error is no larger than it: an error that neighbours do not share is counted by the detection-noise row "
          "and adds up to no smooth field. The scatter s = {:.4f} px (the detection noise row's, {:.0f} dof), its "
          "part that neighbours do not share w = {:.4f} px (second differences of the residuals along the "
          "pattern's lattice, {} triples of neighbours: w^2 = sum d^2 / 6 per coordinate{}); b^2 = max(0, s^2 - "
          "w^2) + 1.645 x the standard uncertainty of s^2 - w^2 were every error white (a one-sided 95% bound: "
          "{:.4f} + {:.4f} px^2), at most s (FitOptions::smooth_bias_scatter_fraction, ::smooth_bound_from_"
          "neighbours; state b with analyze --smooth-bias-px)",
          o.smooth_bias_scatter_fraction, noise_px, c_noise.dof, white.white_px, white.triples, random_note,
          sb.difference_px2, sb.margin_px2) : fmt::format(
          "type B, scaled by measurements: {:g} x the deterministic part of the detector's scatter about the fit "
          "without the pixel-locking signature, on the assumption that a detector's smooth error is no larger than "
          "the part of its corner-to-corner scatter that is not random. The scatter s = {:.4f} px (the detection "
          "noise row's, {:.0f} dof), its random part r = {:.4f} px (the refinement's response to the photo's own "
          "noise drawn again, {} corner coordinates; r^2's standard uncertainty {:.2g} px^2; detect.h "
          "RefinementNoise); b^2 = max(0, s^2 - r^2) + 1.645 x the standard uncertainty of s^2 - r^2 (a one-sided "
          "95% bound: {:.4f} + {:.4f} px^2), at most s (FitOptions::smooth_bias_scatter_fraction; state b with "
          "analyze --smooth-bias-px)",
          o.smooth_bias_scatter_fraction, noise_px, c_noise.dof, setup.random_error_px, setup.random_error_samples,
          setup.random_error_u_px2, sb.difference_px2, sb.margin_px2);
    } else {
      bud.systematic_bound_px = o.smooth_bias_scatter_fraction * noise_px;
      bud.systematic_bound_reason = fmt::format(
          "type B, scaled by a measurement: {:g} x the detector's scatter about the fit without the pixel-locking "
          "signature ({:.4f} px, the detection noise row's), on the assumption that a detector's smooth error is no "
          "larger than its corner-to-corner scatter; its random part was not measured (detect.h RefinementNoise: "
          "tag corners, point-sampled photos, a stated prefilter with a detector's own corners) "
          "(FitOptions::smooth_bias_scatter_fraction; state b with analyze --smooth-bias-px)",
          o.smooth_bias_scatter_fraction, noise_px);
    }
    BudgetComponent c;
    c.name = "detector systematic";
    c.type = "B";
    const std::string signature =
        correction.ok
            ? fmt::format(
                  "the pixel-locking signature, fitted and corrected for: amplitudes in period 1 px x {:.4f} +- "
                  "{:.4f}, y {:.4f} +- {:.4f} px; in period 2 px (a colour filter array's) x {:.4f} +- {:.4f}, y "
                  "{:.4f} +- {:.4f} px{}{}; the correction moved the curvature by {:.3g} 1/mm and the first camera by "
                  "({:.3f}, {:.3f}, {:.3f}) mm, and its uncertainty (G S) C (G S)^T (the coefficients' posterior "
                  "covariance C from the residuals over {} degrees of freedom and the prior N(0, ({} px)^2) per "
                  "coefficient, counted here with the row's infinite ones) is this row's second part",
                  pl.amplitude_px(0, 0), pl.sigma_px(0, 0), pl.amplitude_px(1, 0), pl.sigma_px(1, 0),
                  pl.amplitude_px(0, 1), pl.sigma_px(0, 1), pl.amplitude_px(1, 1), pl.sigma_px(1, 1),
                  pl.tag_border_corners == 0
                      ? std::string()
                      : fmt::format("; and the tags' border shift (outward) x {:.4f} +- {:.4f}, y {:.4f} +- {:.4f} px "
                                    "on {} tag corners (prior N(0, ({} px)^2))",
                                    pl.tag_border_shift_px.x(), pl.tag_border_shift_sigma_px.x(),
                                    pl.tag_border_shift_px.y(), pl.tag_border_shift_sigma_px.y(),
                                    pl.tag_border_corners, kTagBorderPriorPx),
                  fmt::format("; the 2 x 2 cell's cross-phase terms (12 coefficients){}",
                              pl.polarity_corners == 0
                                  ? std::string()
                                  : fmt::format("; and the checkerboard corners' polarity, x {:.4f} +- {:.4f}, y "
                                                "{:.4f} +- {:.4f} px at the cell's mean, on {} corners (10 "
                                                "coefficients)",
                                                pl.polarity_px.x(), pl.polarity_sigma_px.x(), pl.polarity_px.y(),
                                                pl.polarity_sigma_px.y(), pl.polarity_corners)),
                  bud.pixel_locking_correction_curvature_per_mm, bud.pixel_locking_correction_position_mm.x(),
                  bud.pixel_locking_correction_position_mm.y(), bud.pixel_locking_correction_position_mm.z(),
                  w.signature.dof, o.pixel_locking_prior_px)
            : std::string(o.measure_pixel_locking ? "the pixel-locking signature could not be fitted (too few "
                                                    "residuals; without a prior, a shape absorbed by the fit): not "
                                                    "corrected"
                                                  : "the pixel-locking signature not fitted "
                                                    "(FitOptions::measure_pixel_locking off)");
    c.source = fmt::format(
        "a bias field of RMS b = {:.4f} px per coordinate ({}), propagated through the fit's linearization; plus {}",
        bud.systematic_bound_px, bud.systematic_bound_reason, signature);
    c.assumption = fmt::format(
        "the detector's bias other than pixel-locking (moire, corner shape) is smooth across the image and common "
        "to every photo: Legendre fields of total degree <= {} with independent N(0,1) coefficients per "
        "coordinate, each scaled to RMS b ({} seeded draws); its standard uncertainty is the RMS effect. "
        "Pixel-locking is a bias a sin 2 pi phi + b cos 2 pi phi per coordinate, phi the phase of the fit's "
        "prediction in periods of 1 px and 2 px (a colour filter array's demosaicing repeats every 2 px); with it, "
        "per coordinate, the 2 px period's cross terms (the other coordinate's phase and the products of the two: "
        "the error as a function of the position in the array's 2 x 2 cell, to first order in each phase) and, on "
        "a checkerboard, the corner's polarity (its saddle's orientation, alternating along rows and columns) times "
        "1 and the two phases' sin and cos; every coefficient fitted on the shapes' refit projections with the "
        "prior N(0, sigma_b^2) (a coefficient the photos cannot determine stays within the prior), the curvature "
        "and the camera positions corrected by -G S b (the linearized fit with the coefficients as nuisance "
        "parameters: Frisch-Waugh-Lovell); higher harmonics and other periods are not modelled",
        o.systematic_field_degree, o.systematic_field_draws);
    bud.components.push_back(c);
    QuantityVariance v(setup.photos);
    if (lin) {
      const QuantityVariance smooth =
          bud.systematic_bound_px > 0
              ? SystematicVariance(setup, *lin, correction, bud.systematic_bound_px,
                                   LegendreFieldBasis(DetectedPoints(setup, *lin), setup.camera->width,
                                                      setup.camera->height, o.systematic_field_degree))
              : QuantityVariance(setup.photos);
      const QuantityVariance locking = correction.ok ? QuantityVariance::FromCovariance(correction.covariance, setup.photos)
                                                     : QuantityVariance(setup.photos);
      v.var_k = smooth.var_k + locking.var_k;
      for (int p = 0; p < setup.photos; ++p) {
        v.var_pos[static_cast<size_t>(p)] = smooth.var_pos[static_cast<size_t>(p)] + locking.var_pos[static_cast<size_t>(p)];
        v.cov_pos_k[static_cast<size_t>(p)] =
            smooth.cov_pos_k[static_cast<size_t>(p)] + locking.cov_pos_k[static_cast<size_t>(p)];
      }
      bud.pixel_locking_share_curvature_per_mm = std::sqrt(std::max(0.0, locking.var_k));
      if (setup.photos > 0) {
        bud.pixel_locking_correction_sigma_position_mm = locking.var_pos[0].cwiseMax(0.0).cwiseSqrt();
      }
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
  // 4. Lens model misfit: the neighbour statistic and the projection on the misfit family here (the model choice
  // uses it); the field's correlation, and so the row's variance, in CompleteBudget.
  {
    BudgetComponent c;
    c.name = "lens model misfit";
    c.type = "A";
    if (lin && o.measure_lens_misfit) {
      EstimateMisfit(setup, *lin, w.signature.residual_without, noise_px, &bud, &w.lens_field);
    }
    static_assert(kMisfitRow == 3, "the lens model misfit is the budget's fourth row");
    bud.components.push_back(c);
    vars.push_back(QuantityVariance(setup.photos));
  }
  // 5. Pixel pitch: the scene scales with the pitch (R and every position proportional to it, k inversely).
  {
    const double u = o.pitch_tolerance_relative / std::sqrt(3.0);
    QuantityVariance v(setup.photos);
    const double k = fit->curvature_per_mm;
    v.var_k = k * k * u * u;
    for (int p = 0; p < setup.photos && static_cast<size_t>(p) < fit->cameras.size(); ++p) {
      const Eigen::Vector3d c = fit->cameras[static_cast<size_t>(p)].position_in_centre_mm;
      v.var_pos[static_cast<size_t>(p)] = c.cwiseAbs2() * u * u;
      v.cov_pos_k[static_cast<size_t>(p)] = -c * k * u * u;
    }
    BudgetComponent c;
    c.name = "pixel pitch";
    c.type = "B";
    c.distribution = RowDistribution::kRectangular;
    c.source = fmt::format("the datasheet's pixel pitch {:.5f} mm with a tolerance of +-{} (rectangular: u = {}/sqrt(3) "
                           "= {})",
                           setup.nominal->pixel_pitch_mm(), Percent(o.pitch_tolerance_relative),
                           Percent(o.pitch_tolerance_relative), Percent(u));
    c.assumption = "scale is not observable from photos: R and the distances scale with the pitch, u(R)/R = u(p)/p";
    bud.components.push_back(c);
    vars.push_back(v);
  }
}

NormalisedField StatedField(const Setup& setup) {
  const FitOptions& o = *setup.options;
  if (!(o.stated_lens_misfit_px > 0)) return {};
  return NormalisedField::Draw(o.stated_lens_misfit_length_px, setup.camera->width, setup.camera->height,
                               kStatedFieldDraws, o.systematic_field_seed + 5);
}

// The lens-model-misfit row's variance and the combined budget of one candidate (after Budget), replacing its
// sigmas by the combined ones (the curvature's, the cameras' centre-frame positions and their covariance with k).
// The misfit field is a property of the lens and the detector, common to every candidate: it is measured once, on
// the residuals of `reference` (the chosen model; its budget holds the components), and propagated through each
// candidate's own linearization. Returns the rows' variances, the combined last, for FinishBudget.
std::vector<QuantityVariance> CompleteBudget(const Setup& setup, ModelWork& w, const ModelFit& reference,
                                             const NormalisedField* stated_field, ModelFit* fit) {
  const FitOptions& o = *setup.options;
  UncertaintyBudget& bud = fit->budget;
  std::vector<QuantityVariance> vars = w.budget_vars;
  if (vars.empty()) return vars;
  const UncertaintyBudget& ref = reference.budget;
  if (&reference != fit) {
    bud.misfit_components = ref.misfit_components;
    bud.misfit_lags = ref.misfit_lags;
    bud.misfit_length_px = ref.misfit_length_px;
    bud.misfit_variance_px2 = ref.misfit_variance_px2;
    bud.misfit_variance_sd_px2 = ref.misfit_variance_sd_px2;
    bud.misfit_spacing_px = ref.misfit_spacing_px;
    bud.misfit_fit_chi2 = ref.misfit_fit_chi2;
  }
  const std::optional<Linearization>& lin = w.lin;
  BudgetComponent& c = bud.components[kMisfitRow];
  double measured_var_sd = 0;  // the standard uncertainty of the measured row's var(k), from its components
  QuantityVariance& misfit = vars[kMisfitRow];
  if (!bud.misfit_components.empty() && lin) {
    std::string lags, parts;
    for (const UncertaintyBudget::Lag& l : bud.misfit_lags) {
      lags += fmt::format("{}{:.1f}: {:.3g} (noise {:.3g}, field {:.3g})", lags.empty() ? "" : "; ", l.lag_spacings,
                          l.statistic_px2, l.noise_share_px2, l.field_share_px2);
    }
    double var_sum = 0, dof_denominator = 0;
    for (const UncertaintyBudget::FieldComponent& f : bud.misfit_components) {
      const bool ring = f.family == UncertaintyBudget::FieldFamily::kRing;
      parts += fmt::format("{}{} field of RMS {:.4f} px per coordinate (variance {:.3g} +- {:.3g} px^2) at a {} of "
                           "{:.0f} px",
                           parts.empty() ? "" : ", plus a ", ring ? "ring (band-pass)" : "Gaussian",
                           std::sqrt(f.variance_px2), f.variance_px2, f.variance_sd_px2,
                           ring ? "period" : "correlation length", f.length_px);
      if (!(f.variance_px2 > 0)) continue;
      const QuantityVariance part = FieldVariance(setup, *lin, w.correction, f);
      misfit.var_k += part.var_k;
      for (int p = 0; p < setup.photos; ++p) {
        misfit.var_pos[static_cast<size_t>(p)] += part.var_pos[static_cast<size_t>(p)];
        misfit.cov_pos_k[static_cast<size_t>(p)] += part.cov_pos_k[static_cast<size_t>(p)];
      }
      var_sum += part.var_k;
      const double ratio = f.variance_sd_px2 > 0 ? f.variance_px2 / f.variance_sd_px2 : kInf;
      if (std::isfinite(ratio)) dof_denominator += part.var_k * part.var_k / (2 * ratio * ratio);
    }
    if (dof_denominator > 0) c.dof = var_sum * var_sum / dof_denominator;
    measured_var_sd = std::sqrt(2 * dof_denominator);
    c.source = fmt::format(
        "the residuals' correlation at several lags (in feature spacings of {:.1f} px: mean r_a . r_b / 2 in px^2, "
        "{}{}), fitted by stationary fields: a {}; propagated through {} linearization",
        bud.misfit_spacing_px, lags,
        &reference == fit ? "" : fmt::format("; measured on the residuals of the chosen model, {}", reference.model),
        parts, &reference == fit ? "the fit's" : "this model's");
  } else if (!o.measure_lens_misfit) {
    c.source = "none: not measured (FitOptions::measure_lens_misfit off; the lens taken as exact beyond its "
               "calibration)";
  } else {
    c.source = "not measurable here (too few features or pairs)";
  }
  // The calibration's misfit (FitOptions::stated_lens_misfit_px): the row's unless the residuals' field exceeds it
  // significantly (kMisfitExcessSigmas).
  bud.measured_misfit_share_curvature_per_mm = std::sqrt(std::max(0.0, misfit.var_k));
  bud.measured_misfit_share_sd_curvature_per_mm = MisfitShareSd(misfit.var_k, measured_var_sd);
  bud.misfit_row_basis = "residuals";
  std::string stated_rule =
      ". No misfit from the lens's calibration was given (the covariance sidecar's misfit, or analyze --lens-misfit): "
      "one photo's residuals poorly determine the variance of a field much longer than the feature spacing, which "
      "the fit mostly absorbs, so this row can under-state it (docs/bench/validity_bench.txt)";
  if (o.stated_lens_misfit_px > 0 && lin) {
    const UncertaintyBudget::FieldComponent stated{UncertaintyBudget::FieldFamily::kGaussian,
                                                   o.stated_lens_misfit_length_px,
                                                   o.stated_lens_misfit_px * o.stated_lens_misfit_px, 0};
    const QuantityVariance part = FieldVariance(setup, *lin, w.correction, stated);
    bud.stated_misfit_share_curvature_per_mm = std::sqrt(std::max(0.0, part.var_k));
    // The stated RMS is one lens's field over one imager, which that RMS scales: the row's error is drawn
    // (StatedFieldDraws) when it is the row's; the mean square's dof (FieldMeanSquareDof) where it cannot be.
    const double stated_dof =
        FieldMeanSquareDof(o.stated_lens_misfit_length_px, setup.camera->width, setup.camera->height);
    const std::string field = fmt::format(
        "a Gaussian field of RMS {:.4f} px per coordinate at a correlation length of {:.0f} px ({}), one lens's "
        "field scaled to that RMS over the {} x {} px imager",
        o.stated_lens_misfit_px, o.stated_lens_misfit_length_px,
        o.stated_lens_misfit_source.empty() ? "stated" : o.stated_lens_misfit_source, setup.camera->width,
        setup.camera->height);
    const auto distribution = [&](bool drawn) {
      return drawn ? fmt::format("its error distribution drawn ({} draws of the field in the imager's Karhunen-Loeve "
                              "modes, each divided by its own RMS: the mean square's {:.1f} degrees of freedom "
                              "are in the draws)",
                              kStatedFieldDraws, stated_dof)
                : fmt::format("too short a field to draw over this imager: Student's t at its mean square's {:.1f} "
                              "degrees of freedom",
                              stated_dof);
    };
    stated_rule = fmt::format(
        "; the row takes the calibration's field unless the residuals show significantly more: the measured "
        "u(k)^2 above the stated one by more than {:g} of its own standard uncertainty (a one-sided 5% test; "
        "until 2026-12-06 the larger of the two, which is biased upward where both estimate one lens's field)",
        kMisfitExcessSigmas);
    const double measured_excess = misfit.var_k - kMisfitExcessSigmas * measured_var_sd;
    if (part.var_k >= measured_excess) {
      misfit = part;
      if (stated_field) {
        misfit.draws = StatedFieldDraws(setup, *lin, w.correction, *stated_field, fit->curvature_per_mm);
      }
      const bool drawn = !misfit.draws.empty();
      c.source = fmt::format("{}, {}, propagated through {} linearization; the field measured from the residuals "
                             "does not move the curvature significantly more (u(k) {:.3g} against {:.3g} +- {:.2g} "
                             "1/mm, the last from its variance's standard uncertainty), which was: {}",
                             field, distribution(drawn), &reference == fit ? "the fit's" : "this model's",
                             bud.stated_misfit_share_curvature_per_mm,
                             bud.measured_misfit_share_curvature_per_mm,
                             bud.measured_misfit_share_sd_curvature_per_mm, c.source);
      c.type = "B";
      // The coverage factor averages over the draws (no dof), or Student's t at the mean square's dof.
      c.distribution = drawn ? RowDistribution::kSampled : RowDistribution::kNormal;
      c.dof = drawn ? kInf : stated_dof;
      bud.misfit_row_basis = "calibration";
    } else {
      c.source += fmt::format("; it moves the curvature significantly more than the calibration's misfit, {} (u(k) "
                              "{:.3g} +- {:.2g} against {:.3g} 1/mm)",
                              field, bud.measured_misfit_share_curvature_per_mm,
                              bud.measured_misfit_share_sd_curvature_per_mm,
                              bud.stated_misfit_share_curvature_per_mm);
    }
  }
  c.assumption = fmt::format(
      "the true lens departs from its model by stationary fields over the image, independent per coordinate "
      "and common to every photo (and so to every screen model: measured once, on the chosen model's "
      "residuals): up to two Gaussian fields (covariance s^2 exp(-d^2 / 2 L^2)) and one ring field "
      "(band-pass, covariance s^2 J0(2 pi d / P): a beat whose correlation changes sign), fitted through {} "
      "random Fourier features each and propagated with their covariance between every two detections "
      "(through the features above {} detections, {} for a ring); the variances, lengths and period are "
      "those that reproduce the residuals' correlation at 1 to 28 feature spacings after the fit (the part "
      "the fit absorbs into the poses and the screen is inferred from the part it leaves, in the same "
      "family), the combination chosen by AIC. Any other error correlated between features (detector bias "
      "that varies with the image position, moire) is measured here too, so it may be counted twice with the "
      "detector row: conservative. Degrees of freedom 2 (s^2 / u(s^2))^2{}. A calibration's measured misfit, "
      "when given, is a Gaussian field of its RMS and length, type B; that RMS is one lens's over the "
      "imager, so the field is scaled to it: what follows its mean square (the field's mean) is narrower than "
      "normal, what follows its finer structure wider (Student's t-like). The row's distribution is therefore "
      "drawn: the field in the imager's Karhunen-Loeve modes, each draw divided by its own RMS over the imager, "
      "through the same response (distribution 'sampled'; the coverage factors average over the draws). Where "
      "the field is too short to draw (the imager holding more than 800 of its modes, below about 1/22 of the "
      "width), Student's t at the mean square's "
      "degrees of freedom (W H)^2 / (integral over the imager twice of rho(p - p')^2)",
      o.misfit_features, kExactFieldPoints, kExactRingFieldPoints, stated_rule);
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
  // Welch-Satterthwaite on u(k) over every row (reported); the coverage factor from the rows' distributions.
  double denom = 0;
  std::vector<CoverageRow> coverage_rows;
  for (size_t i = 0; i < vars.size(); ++i) {
    if (std::isfinite(bud.components[i].dof)) denom += vars[i].var_k * vars[i].var_k / bud.components[i].dof;
    coverage_rows.push_back({std::sqrt(std::max(0.0, vars[i].var_k)), bud.components[i].dof,
                             bud.components[i].distribution, vars[i].draws.empty() ? nullptr : &vars[i].draws[0]});
  }
  bud.effective_dof = denom > 0 ? total.var_k * total.var_k / denom : kInf;
  bud.coverage_factor = CoverageFactor(o.coverage_probability, coverage_rows);
  bud.coverage_factor68 = CoverageFactor(kCoverage68, coverage_rows);
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
  // Each camera coordinate's coverage factors from its own rows (the pitch row's share differs per coordinate).
  for (int a = 0; a < 3; ++a) {
    for (const bool axis : {false, true}) {
      if (axis && a < 2) {  // the axis frame's x and y are the centre frame's: the same rows
        bud.position_factor.axis[a] = bud.position_factor.centre[a];
        bud.position_factor68.axis[a] = bud.position_factor68.centre[a];
        continue;
      }
      std::vector<CoverageRow> rows;
      bool finite = true;
      // A sampled row's draws: k's, then the centre frame's x, y, z, then the axis frame's z (its x and y are the
      // centre frame's).
      const size_t drawn = axis && a == 2 && radius ? 4 : static_cast<size_t>(1 + a);
      for (size_t i = 0; i < bud.components.size(); ++i) {
        const BudgetComponent& c = bud.components[i];
        const double u = axis ? c.position_in_axis_mm[a] : c.position_in_centre_mm[a];
        finite = finite && std::isfinite(u);
        rows.push_back({finite ? u : 0, c.dof, c.distribution,
                        vars[i].draws.size() > drawn ? &vars[i].draws[drawn] : nullptr});
      }
      (axis ? bud.position_factor.axis : bud.position_factor.centre)[a] =
          finite ? CoverageFactor(bud.coverage_probability, rows) : bud.coverage_factor;
      (axis ? bud.position_factor68.axis : bud.position_factor68.centre)[a] =
          finite ? CoverageFactor(kCoverage68, rows) : bud.coverage_factor68;
    }
  }
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

}  // namespace curvecheck::screen_fit_internal
