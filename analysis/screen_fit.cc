#include "analysis/screen_fit.h"

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <cmath>
#include <set>
#include <unordered_map>

#include "analysis/screen_fit_cost.h"
#include "analysis/screen_fit_internal.h"
#include "analysis/screen_model.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"

namespace curvecheck::screen_fit_internal {
namespace {

// Radius, its interval and the screen-frame camera positions from the curvature and its sigma.
void RadiusFromCurvature(const Setup& setup, const ModelWork& w, ModelFit* fit) {
  const double k = fit->curvature_per_mm, sk = fit->curvature_sigma_per_mm;
  const bool curved_model = fit->model != "flat";
  // The interval from the combined standard uncertainty and its coverage factor (the normal 1.96 without a
  // budget).
  const double cover = fit->budget.computed ? fit->budget.coverage_factor : kZ95;
  const double lo = k - cover * sk, hi = k + cover * sk;
  const double max_relative = setup.options->max_relative_curvature_sigma;
  if (curved_model && (lo > 0 || hi < 0) && sk > max_relative * std::abs(k)) {
    // Significantly curved, but too poorly determined for a number. The bound is on |R| (a size, never below
    // zero), from the curvature interval's end farthest from flat; for a curvature of the other sign (a convex fit)
    // 1/lo and 1/hi are negative and would print as "lower bound -5503 mm".
    fit->radius_ci95_mm = {std::min(1 / lo, 1 / hi), std::max(1 / lo, 1 / hi)};
    fit->radius_lower_bound_mm = 1 / std::max(std::abs(lo), std::abs(hi));
    fit->ill_conditioned = true;
    fit->condition_note += fmt::format(
        "radius unobservable from these photos: the curvature {:.3g} +- {:.3g} /m has a relative sigma of {:.0f}% "
        "(limit {:.0f}%), a 95% interval of R from {:.0f} to {:.0f} mm: the radius is not determined by these "
        "photos; take more photos from other positions (closer, and from the sides). ",
        k * 1000, sk * 1000, 100 * sk / std::abs(k), 100 * max_relative, fit->radius_ci95_mm[0],
        fit->radius_ci95_mm[1]);
  } else if (curved_model && (lo > 0 || hi < 0)) {
    fit->radius_mm = 1 / k;
    fit->radius_sigma_mm = sk / (k * k);
    fit->radius_ci95_mm = {std::min(1 / lo, 1 / hi), std::max(1 / lo, 1 / hi)};
    if (fit->budget.computed) {
      // Inside the 95% interval, so of the same sign as k.
      const double lo68 = k - fit->budget.coverage_factor68 * sk, hi68 = k + fit->budget.coverage_factor68 * sk;
      fit->radius_ci68_mm = {std::min(1 / lo68, 1 / hi68), std::max(1 / lo68, 1 / hi68)};
    }
  } else if (curved_model) {
    fit->radius_lower_bound_mm = 1 / std::max(std::abs(lo), std::abs(hi));
    fit->radius_ci95_mm = {fit->radius_lower_bound_mm, kInf};
    const double k_nominal = setup.nominal->curvature_per_mm;
    if (k_nominal != 0 && lo <= k_nominal && k_nominal <= hi) {
      fit->ill_conditioned = true;
      fit->condition_note += fmt::format(
          "radius unobservable from these photos: the 95% interval of the curvature [{:.3g}, {:.3g}] /m holds both "
          "flat and the nominal {:.0f} mm; photograph from closer or more obliquely. ",
          lo * 1000, hi * 1000, 1 / k_nominal);
    }
  }
  for (size_t p = 0; p < fit->cameras.size(); ++p) {
    CameraEstimate& cam = fit->cameras[p];
    cam.position_in_screen_mm = cam.position_in_centre_mm;
    cam.position_in_screen_sigma_mm = cam.position_in_centre_sigma_mm;
    if (!fit->radius_mm) continue;
    // z_screen = c_z - R with R = 1/k: dR/dk = -1/k^2, so var = var(c_z) + var(k)/k^4 + 2 cov(c_z, k)/k^2.
    cam.position_in_screen_mm.z() -= *fit->radius_mm;
    const double k2 = k * k, cov_zk = w.position_curvature_cov[p].z();
    const double sz = cam.position_in_centre_sigma_mm.z();
    cam.position_in_screen_sigma_mm.z() =
        std::sqrt(std::max(0.0, sz * sz + sk * sk / (k2 * k2) + 2 * cov_zk / k2));
  }
}

// Fits one model: robust pass (outlier flags for the common set), then called again by FitFinal.
void FitRobust(const Setup& setup, ModelWork& w, const std::vector<bool>& active) {
  BuiltProblem b = Build(setup, w.kind, w.basis.get(), active, true, &w.state);
  const ceres::Solver::Summary s = Solve(setup, b, &w.state);
  w.robust_ok = s.IsSolutionUsable();
  w.robust_iterations = static_cast<int>(s.iterations.size());
  w.robust_residuals = Residuals(setup, w.kind, w.basis.get(), w.state);
}

void FitFinal(const Setup& setup, ModelWork& w, const std::vector<bool>& inlier, ModelFit* fit) {
  BuiltProblem b = Build(setup, w.kind, w.basis.get(), inlier, false, &w.state);
  const ceres::Solver::Summary s = Solve(setup, b, &w.state);
  fit->converged = s.termination_type == ceres::CONVERGENCE;
  fit->iterations = w.robust_iterations + static_cast<int>(s.iterations.size());
  if (!fit->converged) {
    fit->condition_note += fmt::format("solver: {} after {} iterations. ", s.message, s.iterations.size());
  }
  const std::vector<Eigen::Vector2d> r = Residuals(setup, w.kind, w.basis.get(), w.state);
  double rss = 0;
  int n_in = 0;
  fit->residual_px.assign(static_cast<size_t>(setup.photos), {});
  fit->outlier.assign(static_cast<size_t>(setup.photos), {});
  for (size_t i = 0; i < setup.obs.size(); ++i) {
    fit->residual_px[static_cast<size_t>(setup.obs[i].photo)].push_back(r[i]);
    fit->outlier[static_cast<size_t>(setup.obs[i].photo)].push_back(!inlier[i]);
    if (inlier[i] && r[i].allFinite()) {
      rss += r[i].squaredNorm();
      ++n_in;
    }
  }
  const int n = 2 * n_in;
  fit->parameters = static_cast<int>(w.state.core.size() + w.state.dev.size() + w.state.intr.size()) + 6 * setup.photos;
  fit->rms_px = std::sqrt(rss / std::max(1, n_in));
  fit->noise_px = std::sqrt(rss / std::max(1, n - fit->parameters));
  // BIC with the residual sum floored at the detections' systematic error (FitOptions::noise_floor_px).
  const double floor_rss = n * setup.options->noise_floor_px * setup.options->noise_floor_px;
  fit->bic = n * std::log(std::max({rss, floor_rss, 1e-300}) / n) +
             fit->parameters * std::log(static_cast<double>(n));
  fit->shape = w.state.core;
  fit->shape.insert(fit->shape.end(), w.state.dev.begin(), w.state.dev.end());
  fit->deviation_basis_curvature_per_mm = w.basis ? w.basis_curvature_per_mm : 0;
  w.lin = Linearize(setup, w, b, &fit->budget.note);
  Covariances(setup, w, fit);
  if (fit->cameras.size() == static_cast<size_t>(setup.photos)) Budget(setup, w, n, fit);
  Adequacy(*setup.options, rss, n, fit);
}

// Once the model is chosen: the lens-model-misfit field measured on the chosen model's residuals, then every
// candidate's budget completed with it (CompleteBudget), its radius and interval.
void CompleteFits(const Setup& setup, std::vector<ModelWork>& work, ScreenFitResult* result) {
  if (result->chosen < 0 || static_cast<size_t>(result->chosen) >= work.size()) return;
  ModelFit& chosen = result->candidates[static_cast<size_t>(result->chosen)];
  const ModelWork& cw = work[static_cast<size_t>(result->chosen)];
  if (cw.lin && setup.options->measure_lens_misfit) {
    MeasureMisfitCorrelation(setup, *cw.lin, cw.signature.residual_without, IndependentNoisePx(chosen),
                             &chosen.budget);
  }
  // The stated misfit's field is the lens's: drawn once, answered by each candidate.
  const NormalisedField stated_field = StatedField(setup);
  // On all cores: each candidate writes only its own fit; the chosen one's misfit fields, which the others copy,
  // are not written here.
  ParallelFor(static_cast<int>(work.size()), [&](int k) {
    const size_t i = static_cast<size_t>(k);
    ModelFit& fit = result->candidates[i];
    const std::vector<QuantityVariance> vars = CompleteBudget(setup, work[i], chosen, &stated_field, &fit);
    RadiusFromCurvature(setup, work[i], &fit);
    FinishBudget(vars, &fit);
  });
}

void Deviations(const Setup& setup, const ModelWork& w, ScreenFitResult* result) {
  const FitOptions& opt = *setup.options;
  const ModelFit& fit = result->Chosen();
  const bool field = w.kind == ScreenModelKind::kCylinderDeviation;
  const auto field_at = [&](const Eigen::Vector2d& uv) {
    return field ? w.basis->Weights(uv).dot(Eigen::Map<const Eigen::VectorXd>(w.state.dev.data(),
                                                                                static_cast<long>(w.state.dev.size())))
                 : 0.0;
  };
  std::vector<int> index_in_photo(static_cast<size_t>(setup.photos), 0);
  for (const Obs& o : setup.obs) {
    FeatureDeviation d;
    d.photo = o.photo;
    d.id = setup.feature_ids[static_cast<size_t>(o.feature)];
    d.uv = o.uv;
    const Eigen::Vector2d r = fit.residual_px[static_cast<size_t>(o.photo)][static_cast<size_t>(o.index)];
    d.outlier = fit.outlier[static_cast<size_t>(o.photo)][static_cast<size_t>(o.index)];
    const std::vector<const double*> blocks = Blocks(w.state, o.photo);
    Eigen::Vector2d q, dq_dn;
    const bool ok = MakeCost(setup, w.kind, w.basis.get(), o)->PredictWithNormal(blocks.data(), &q, &dq_dn);
    const double g = ok ? dq_dn.norm() : 0;
    const double g_floor = std::max(g, 1e-6);
    d.normal_mm = field_at(o.uv) + (g > 1e-6 && r.allFinite() ? dq_dn.dot(r) / (g * g) : 0.0);
    d.sigma_mm = result->noise_px / g_floor;
    result->deviations.push_back(d);
  }
  // Map.
  result->map_nu = opt.map_nu;
  result->map_nv = opt.map_nv;
  result->map_mm.assign(static_cast<size_t>(opt.map_nu * opt.map_nv), kNaN);
  result->map_sigma_mm.assign(result->map_mm.size(), kNaN);
  for (int j = 0; j < opt.map_nv; ++j) {
    for (int i = 0; i < opt.map_nu; ++i) {
      const Eigen::Vector2d uv(-1 + (2 * i + 1.0) / opt.map_nu, -1 + (2 * j + 1.0) / opt.map_nv);
      const size_t cell = static_cast<size_t>(j * opt.map_nu + i);
      bool supported = false;
      double sw = 0, swd = 0;
      const double reach2 = std::max(16 * opt.map_smoothing_uv * opt.map_smoothing_uv,
                                     opt.map_support_uv * opt.map_support_uv);
      for (const FeatureDeviation& d : result->deviations) {
        if (d.outlier) continue;
        const double dist2 = (d.uv - uv).squaredNorm();
        if (dist2 > reach2) continue;  // beyond 4 kernel sigmas: weight below 3e-4
        if (dist2 <= opt.map_support_uv * opt.map_support_uv) supported = true;
        const double kern = std::exp(-0.5 * dist2 / (opt.map_smoothing_uv * opt.map_smoothing_uv));
        const double wt = kern / (d.sigma_mm * d.sigma_mm);
        sw += wt;
        swd += wt * d.normal_mm;
      }
      if (!supported) continue;
      if (field) {
        const Eigen::VectorXd wv = w.basis->Weights(uv);
        result->map_mm[cell] = field_at(uv);
        result->map_sigma_mm[cell] =
            w.dev_covariance.size() > 0 ? std::sqrt(std::max(0.0, wv.dot(w.dev_covariance * wv))) : kNaN;
      } else if (sw > 0) {
        const double sigma = 1 / std::sqrt(sw);
        if (sigma > opt.map_max_sigma_mm) continue;
        result->map_mm[cell] = swd / sw;
        result->map_sigma_mm[cell] = sigma;
      }
    }
  }
}

// The warning for an inadequate chosen model: its figures, per photo when there are several (a wrong pattern.json
// shows in one photo), and the likely causes.
std::string InadequacyWarning(const std::vector<PhotoObservations>& photos, const ScreenFitResult& result) {
  const ModelFit& m = result.Chosen();
  std::string s = fmt::format(
      "{}: inadequate: the fit's residual noise is {:.3f} px per coordinate (RMS {:.3f} px), {:.1f} times the {} "
      "detection noise of {:.3f} px (limit {:.3f} px); chi2/dof = {:.4g}/{} = {:.3g}, p = {:.2g}.",
      m.model, m.noise_px, m.rms_px, m.noise_ratio,
      result.detection_noise_assumed ? "assumed (not measured: --expected-noise)" : "measured",
      result.detection_noise_px, result.adequacy_limit_px, m.chi2, m.dof, m.dof > 0 ? m.chi2 / m.dof : kNaN,
      m.chi2_p_value);
  std::string others;
  for (const ModelFit& c : result.candidates) {
    if (&c == &m) continue;
    others += fmt::format("{}{} {:.3f} px", others.empty() ? "" : ", ", c.model, c.noise_px);
  }
  s += others.empty() ? " It was the only model tried." : " No candidate fits better than that (" + others + ").";
  if (m.residual_px.size() > 1) {
    // Per-photo RMS of the inliers: the worst photo and the median of the others.
    std::vector<std::pair<double, size_t>> rms;
    for (size_t p = 0; p < m.residual_px.size(); ++p) {
      double sum = 0;
      int count = 0;
      for (size_t i = 0; i < m.residual_px[p].size(); ++i) {
        if (m.outlier[p][i] || !m.residual_px[p][i].allFinite()) continue;
        sum += m.residual_px[p][i].squaredNorm();
        ++count;
      }
      rms.emplace_back(count > 0 ? std::sqrt(sum / count) : kNaN, p);
    }
    std::sort(rms.begin(), rms.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<double> rest;
    for (size_t i = 1; i < rms.size(); ++i) rest.push_back(rms[i].first);
    const std::string& name = photos[rms[0].second].photo;
    s += fmt::format(" Worst photo: {} with an RMS of {:.3f} px (median of the other {}: {:.3f} px).",
                     name.empty() ? fmt::format("photo {}", rms[0].second + 1) : name, rms[0].first, rest.size(),
                     Median(rest));
  }
  s += " Its parameters are not measurements. Likely causes: the wrong pattern.json for a photo (e.g. two "
       "--pattern files in the wrong order), the wrong camera model (another camera's or another focus's "
       "calibration), a mirrored photo, or a screen that no model in the list fits (e.g. --models flat on a curved "
       "monitor).";
  return s;
}

// The chosen model's curvature against the nominal: a radius beyond both 5 sigma and 25% of the nominal, a flat
// screen measured on a monitor specified curved, or a curved one on a monitor specified flat.
std::optional<std::string> PlausibilityWarning(const Monitor& nominal, const ScreenFitResult& result) {
  const ModelFit& m = result.Chosen();
  const double kn = nominal.curvature_per_mm;
  if (m.radius_mm) {
    const double r = *m.radius_mm, sr = m.radius_sigma_mm.value_or(kNaN);
    if (kn == 0) {
      return fmt::format(
          "{}: implausible: the screen measures curved, R = {:.0f} +- {:.0f} mm (95% interval {:.0f} to {:.0f} mm), "
          "but the monitor is specified flat; check the monitor given, and the camera model (a wrong lens model "
          "bends straight lines).",
          m.model, r, sr, m.radius_ci95_mm[0], m.radius_ci95_mm[1]);
    }
    const double rn = 1 / kn, d = r - rn;
    if (std::abs(d) > 5 * sr && std::abs(d) > 0.25 * std::abs(rn)) {
      return fmt::format(
          "{}: implausible: the radius {:.0f} +- {:.0f} mm is {:+.0f} mm ({:+.0f}%, {:.0f} sigma) from the nominal "
          "{:.0f} mm; check the monitor given (its radius and pixel pitch: the scale of the fit is the pitch's), "
          "the camera model and the pattern.json.",
          m.model, r, sr, d, 100 * d / std::abs(rn), std::abs(d) / sr, rn);
    }
    return std::nullopt;
  }
  if (kn == 0) return std::nullopt;
  // No radius: the flat model, or a curved model whose 95% interval holds flat. The evidence about the curvature
  // is the chosen model's own, or the cylinder's when flat was chosen. An ill-conditioned one says that the
  // photos cannot tell (its own warning); none fitted: only flat was tried.
  const ModelFit* evidence = &m;
  if (m.model == "flat") {
    evidence = nullptr;
    for (const ModelFit& c : result.candidates) {
      if (c.model == "cylinder") evidence = &c;
    }
    if (!evidence) {
      return fmt::format(
          "flat: implausible: a flat screen was fitted to a monitor specified {:.0f}R and no curved model was tried "
          "(check --models); the curvature was not measured.",
          1 / kn);
    }
  }
  if (evidence->ill_conditioned || !evidence->converged) return std::nullopt;
  const double k = evidence->curvature_per_mm, sk = evidence->curvature_sigma_per_mm;
  const bool far = std::abs(k - kn) > 5 * sk && (k * kn <= 0 || std::abs(1 / k - 1 / kn) > 0.25 * std::abs(1 / kn));
  if (!far) return std::nullopt;
  return fmt::format(
      "{}: implausible: the screen measures flat on a monitor specified {:.0f}R: the {} curvature is {:.3g} +- {:.3g} "
      "/m (R beyond {:.0f} mm at 95%), {:.0f} sigma from the nominal {:.3g} /m; check the monitor given, and the "
      "pattern.json and camera model.",
      m.model, 1 / kn, evidence->model, 1000 * k, 1000 * sk, evidence->radius_lower_bound_mm,
      sk > 0 ? std::abs(k - kn) / sk : kInf, 1000 * kn);
}

void CheckPhotos(const std::vector<PhotoObservations>& photos, const FitOptions& options) {
  if (photos.empty()) throw Error("fit", "no photos to fit", "give at least one photo with detected features");
  for (const PhotoObservations& p : photos) {
    const std::string where = p.photo.empty() ? "fit" : p.photo;
    if (p.ids.size() != p.display_px.size() || p.ids.size() != p.detected_px.size()) {
      throw Error(where,
                  fmt::format("{} ids, {} display positions and {} detections do not match", p.ids.size(),
                              p.display_px.size(), p.detected_px.size()),
                  "give one display position and one detection per feature id");
    }
    if (static_cast<int>(p.ids.size()) < options.min_features_per_photo) {
      throw Error(where, fmt::format("only {} features", p.ids.size()),
                  fmt::format("a photo needs at least {} detected features", options.min_features_per_photo));
    }
    std::set<std::string> seen;
    for (size_t i = 0; i < p.ids.size(); ++i) {
      if (!p.display_px[i].allFinite() || !p.detected_px[i].allFinite()) {
        throw Error(where, fmt::format("feature '{}' has a position that is not finite", p.ids[i]),
                    "drop features that were not detected");
      }
      if (!seen.insert(p.ids[i]).second) {
        throw Error(where, fmt::format("feature '{}' appears twice", p.ids[i]), "give each feature once per photo");
      }
    }
  }
}

}  // namespace

// The detection noise the candidates are tested against, and the residual noise a model may reach.
double DetectionSigma(const FitOptions& o) {
  return o.detection_noise_px > 0 ? o.detection_noise_px : o.expected_noise_px;
}
double AdequacyLimit(const FitOptions& o) {
  const double sigma = DetectionSigma(o);
  return std::max(o.adequacy_noise_ratio * sigma, sigma + o.noise_floor_px);
}

// The goodness-of-fit test of one candidate (FitOptions::adequacy_p_value) over its inliers' residual sum.
// rss: the plain residual sum, or the one left after the lens model misfit (AdjustForLensField; `what` says so).
void Adequacy(const FitOptions& o, double rss, int n, ModelFit* fit, const std::string& what) {
  const double sigma = DetectionSigma(o);
  fit->dof = n - fit->parameters;
  fit->chi2 = rss / (sigma * sigma);
  fit->chi2_p_value = ChiSquareUpperTail(fit->chi2, fit->dof);  // NaN without degrees of freedom: not testable
  const double noise = std::sqrt(rss / std::max(1, fit->dof));   // noise_px for the plain sum
  fit->noise_ratio = noise / sigma;
  const double limit = AdequacyLimit(o);
  fit->adequate = !(fit->chi2_p_value < o.adequacy_p_value && noise > limit);
  fit->adequacy_note.clear();
  if (!fit->adequate) {
    fit->adequacy_note = fmt::format(
        "residual noise {:.3f} px per coordinate{} (RMS {:.3f} px), {:.2f} times the detection noise {:.3f} px "
        "(limit {:.3f} px); chi2/dof = {:.4g}/{} = {:.3g}, p = {:.2g}",
        noise, what, fit->rms_px, fit->noise_ratio, sigma, limit, fit->chi2, fit->dof, fit->chi2 / fit->dof,
        fit->chi2_p_value);
  }
}

}  // namespace curvecheck::screen_fit_internal

namespace curvecheck {

using namespace screen_fit_internal;  // NOLINT: this file implements screen_fit.h with them

void FitOptions::Check(const std::string& where) const {
  if (models.empty()) throw Error(where, "no screen models to try", "give at least one, e.g. cylinder");
  const auto positive = [&](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) {
      throw Error(where, fmt::format("{} is {}, but must be a positive number", name, v), "");
    }
  };
  // Named as the user sets it (analyze --expected-noise), not by this field's name.
  if (!(expected_noise_px > 0) || !std::isfinite(expected_noise_px)) {
    throw Error("--expected-noise", fmt::format("{} px is not a detection noise level", expected_noise_px),
                "give the expected detection noise per coordinate in px, a positive number such as 0.15");
  }
  if (!(detection_noise_px >= 0) || !std::isfinite(detection_noise_px)) {
    throw Error(where, fmt::format("detection_noise_px is {}, but must be 0 (unknown) or a positive number",
                                   detection_noise_px),
                "");
  }
  if (!(adequacy_p_value > 0 && adequacy_p_value < 1)) {
    throw Error(where, fmt::format("adequacy_p_value is {}, but must be between 0 and 1", adequacy_p_value),
                "give e.g. 0.001");
  }
  if (!(adequacy_noise_ratio >= 1) || !std::isfinite(adequacy_noise_ratio)) {
    throw Error(where, fmt::format("adequacy_noise_ratio is {}, but must be 1 or more", adequacy_noise_ratio),
                "give e.g. 1.5");
  }
  if (smooth_bias_px && (!(*smooth_bias_px >= 0) || !std::isfinite(*smooth_bias_px))) {
    // Named as the user sets it (analyze --smooth-bias-px).
    throw Error("--smooth-bias-px", fmt::format("{} px is not a smooth detector bias", *smooth_bias_px),
                "give the RMS per coordinate in px (0: none), or leave it out to take it from the detector's scatter");
  }
  if (!(smooth_bias_scatter_fraction >= 0) || !std::isfinite(smooth_bias_scatter_fraction)) {
    throw Error(where,
                fmt::format("smooth_bias_scatter_fraction is {}, but must be 0 or a positive number",
                            smooth_bias_scatter_fraction),
                "give e.g. 1");
  }
  if (!(pixel_locking_prior_px >= 0) || !std::isfinite(pixel_locking_prior_px)) {
    throw Error(where, fmt::format("pixel_locking_prior_px is {}, but must be a positive number (or 0: no prior)",
                                   pixel_locking_prior_px),
                "give e.g. 0.1");
  }
  if (!(noise_floor_px >= 0) || !std::isfinite(noise_floor_px)) {
    throw Error(where, fmt::format("noise_floor_px is {}, but must be 0 or a positive number", noise_floor_px), "");
  }
  positive(huber_sigmas, "huber_sigmas");
  positive(outlier_sigmas, "outlier_sigmas");
  positive(deviation_prior_mm, "deviation_prior_mm");
  positive(map_smoothing_uv, "map_smoothing_uv");
  positive(map_support_uv, "map_support_uv");
  positive(map_max_sigma_mm, "map_max_sigma_mm");
  if (!(outlier_min_px >= 0)) throw Error(where, "outlier_min_px is negative", "give 0 or more");
  if (!(bic_margin >= 0)) throw Error(where, "bic_margin is negative", "give 0 or more (10: very strong)");
  if (!(heldout_tolerance >= 0)) throw Error(where, "heldout_tolerance is negative", "give e.g. 0.05");
  if (heldout_folds < 0 || heldout_folds == 1) {
    throw Error(where, fmt::format("heldout_folds is {}", heldout_folds), "give 0 (off) or 2 or more");
  }
  if (deviation_nu < 4 || deviation_nv < 4) {
    throw Error(where, "the deviation field needs at least 4 x 4 coefficients", "raise deviation_nu/nv");
  }
  if (map_nu < 1 || map_nv < 1) throw Error(where, "the deviation map needs at least 1 x 1 cells", "");
  if (max_iterations < 1) throw Error(where, "max_iterations must be at least 1", "");
  if (min_features_per_photo < 6) throw Error(where, "min_features_per_photo below 6 leaves the pose free", "");
  positive(max_relative_curvature_sigma, "max_relative_curvature_sigma");
  if (!(pitch_tolerance_relative >= 0 && pitch_tolerance_relative < 0.5)) {
    throw Error(where, fmt::format("the pixel-pitch tolerance is {}, but must be a fraction in [0, 0.5)",
                                   pitch_tolerance_relative),
                "give e.g. 0.001 for 0.1%");
  }
  if (systematic_field_degree < 0 || systematic_field_degree > 8) {
    throw Error(where, fmt::format("systematic_field_degree is {}", systematic_field_degree), "give 0 to 8 (3)");
  }
  if (misfit_field_degree < 1 || misfit_field_degree > 12) {
    throw Error(where, fmt::format("misfit_field_degree is {}", misfit_field_degree), "give 1 to 12 (6)");
  }
  if (systematic_field_draws < 10) throw Error(where, "systematic_field_draws below 10", "give e.g. 2000");
  if (!(coverage_probability > 0 && coverage_probability < 1)) {
    throw Error(where, fmt::format("coverage_probability is {}", coverage_probability), "give e.g. 0.95");
  }
  if (intrinsics_covariance.rows() != intrinsics_covariance.cols() || !intrinsics_covariance.allFinite()) {
    throw Error(where, "the intrinsics covariance is not a finite square matrix", "");
  }
  if (!IsLensMisfitField(stated_lens_misfit_px, stated_lens_misfit_length_px)) {
    throw Error(stated_lens_misfit_source.empty() ? where : stated_lens_misfit_source,
                fmt::format("the stated lens model misfit is {} px RMS at a length of {} px",
                            stated_lens_misfit_px, stated_lens_misfit_length_px),
                "give an RMS of 0 to 100 px and a positive correlation length in px");
  }
}

bool IsLensMisfitField(double rms_px, double length_px) {
  return rms_px >= 0 && rms_px < 100 && (rms_px == 0 || (length_px > 0 && std::isfinite(length_px)));
}

double PitchToleranceFromPercent(double percent, const std::string& option) {
  if (!(percent >= 0 && percent < 50)) {
    throw Error(option, fmt::format("{} % is not a tolerance", percent), "give a percentage from 0 to 50, e.g. 0.1");
  }
  return percent / 100;
}

ScreenFitResult FitScreen(const Monitor& nominal, const CameraModel& camera,
                          const std::vector<PhotoObservations>& photos, const FitOptions& options) {
  nominal.Check("nominal monitor");
  camera.Check("camera model");
  options.Check("fit options");
  if (options.intrinsics_covariance.size() > 0 &&
      options.intrinsics_covariance.rows() != static_cast<long>(camera.intrinsics.size())) {
    throw Error(options.intrinsics_covariance_source.empty() ? "fit options" : options.intrinsics_covariance_source,
                fmt::format("the intrinsics covariance is {} x {}, but the camera model has {} intrinsics",
                            options.intrinsics_covariance.rows(), options.intrinsics_covariance.cols(),
                            camera.intrinsics.size()),
                "give the covariance written with this camera model");
  }
  CheckPhotos(photos, options);

  Setup setup;
  setup.nominal = &nominal;
  setup.camera = &camera;
  setup.projector.emplace(camera);
  setup.options = &options;
  setup.photos = static_cast<int>(photos.size());
  setup.half_width_mm = 0.5 * nominal.width_mm;
  // The photos' r^2 pooled by their samples n_i: sum n_i r_i^2 / N, of variance sum (n_i / N)^2 (2 r_i u_i)^2.
  double random_sum2 = 0, random_var_sum = 0;
  for (const PhotoObservations& ph : photos) {
    if (ph.random_error_samples <= 0 || !std::isfinite(ph.random_error_px) || !std::isfinite(ph.random_error_u_px)) {
      continue;
    }
    const double n = static_cast<double>(ph.random_error_samples);
    random_sum2 += n * ph.random_error_px * ph.random_error_px;
    random_var_sum += std::pow(n * 2 * ph.random_error_px * ph.random_error_u_px, 2);
    setup.random_error_samples += ph.random_error_samples;
  }
  if (setup.random_error_samples > 0) {
    const double total = static_cast<double>(setup.random_error_samples);
    setup.random_error_px = std::sqrt(random_sum2 / total);
    setup.random_error_u_px2 = std::sqrt(random_var_sum) / total;
  }
  std::unordered_map<std::string, int> feature_index;
  for (size_t p = 0; p < photos.size(); ++p) {
    for (size_t i = 0; i < photos[p].ids.size(); ++i) {
      Obs o;
      o.photo = static_cast<int>(p);
      o.index = static_cast<int>(i);
      auto [it, inserted] = feature_index.emplace(photos[p].ids[i], static_cast<int>(setup.feature_ids.size()));
      if (inserted) setup.feature_ids.push_back(photos[p].ids[i]);
      o.feature = it->second;
      o.uv = UvFromDisplayPx(nominal, photos[p].display_px[i]);
      o.s_mm = 0.5 * o.uv.x() * nominal.width_mm;
      o.y_mm = -0.5 * o.uv.y() * nominal.height_mm;
      o.detected = photos[p].detected_px[i];
      setup.obs.push_back(o);
    }
  }

  std::vector<ScreenModelKind> kinds;
  for (ScreenModelKind k : AllScreenModels()) {
    if (std::find(options.models.begin(), options.models.end(), k) != options.models.end()) {
      kinds.push_back(k);
    }
  }

  // Initial poses from PnP against the nominal surface.
  State initial;
  for (int p = 0; p < setup.photos; ++p) initial.poses.push_back(InitialPose(setup, p));

  // Pass 1: robust fits, in order of complexity; richer models start from the cylinder's solution. The models up
  // to the cylinder start from the PnP poses and are fitted together, then the richer ones together (on all cores).
  ScreenFitResult result;
  std::vector<ModelWork> work;
  const std::vector<bool> all(setup.obs.size(), true);
  int fewest = std::numeric_limits<int>::max();  // parameters of the simplest model asked for
  for (ScreenModelKind kind : kinds) {
    // A model needs at least 3 residuals per parameter (shape and poses) to be worth fitting and comparing.
    const int shape_parameters =
        CoreParameterCount(kind) +
        (kind == ScreenModelKind::kCylinderDeviation ? options.deviation_nu * options.deviation_nv - 5 : 0);
    const int parameters =
        shape_parameters + 6 * setup.photos + (options.fit_intrinsics ? static_cast<int>(camera.intrinsics.size()) : 0);
    fewest = std::min(fewest, parameters);
    if (2 * static_cast<int>(setup.obs.size()) < 3 * parameters) {
      result.skipped.push_back(fmt::format(
          "{} not tried: {} observations give {} residuals, fewer than 3 per parameter ({} parameters); use a "
          "denser pattern or more photos",
          ScreenModelName(kind), setup.obs.size(), 2 * setup.obs.size(), parameters));
      continue;
    }
    work.emplace_back().kind = kind;
  }
  if (work.empty()) {
    throw TooFewObservationsError(
        "screen fit",
        fmt::format("no screen model could be fitted: {} observations in {} photo(s) give {} residuals, and the "
                    "simplest model asked for has {} parameters (at least 3 residuals per parameter: {} observations)",
                    setup.obs.size(), setup.photos, 2 * setup.obs.size(), fewest, (3 * fewest + 1) / 2),
        "photograph the pattern larger or from nearer (more features), or add photos");
  }
  std::vector<double> time_ms(work.size(), 0.0);
  const auto robust = [&](size_t i, const State* from) {
    const Stopwatch watch;
    ModelWork& w = work[i];
    w.state.poses = from ? from->poses : initial.poses;
    if (options.fit_intrinsics) w.state.intr = from ? from->intr : camera.intrinsics;
    const double k0 = from ? from->core[0] : nominal.curvature_per_mm;
    w.state.core.assign(static_cast<size_t>(CoreParameterCount(w.kind)), 0.0);
    if (!w.state.core.empty()) w.state.core[0] = k0;
    if (w.kind == ScreenModelKind::kCylinderDeviation) {
      w.basis = std::make_unique<DeviationBasis>(nominal, k0, options.deviation_nu, options.deviation_nv);
      w.basis_curvature_per_mm = k0;
      w.state.dev.assign(static_cast<size_t>(w.basis->size()), 0.0);
    }
    FitRobust(setup, w, all);
    time_ms[i] = watch.Ms();
  };
  size_t first_rich = 0;  // the models after the cylinder
  while (first_rich < work.size() && work[first_rich].kind <= ScreenModelKind::kCylinder) ++first_rich;
  ParallelFor(static_cast<int>(first_rich), [&](int i) { robust(static_cast<size_t>(i), nullptr); });
  int cylinder = -1;  // index into work
  for (size_t i = 0; i < first_rich; ++i) {
    if (work[i].kind == ScreenModelKind::kCylinder && work[i].robust_ok) cylinder = static_cast<int>(i);
  }
  const State* from = cylinder >= 0 ? &work[static_cast<size_t>(cylinder)].state : nullptr;
  // The richest (slowest) first.
  const int rich = static_cast<int>(work.size() - first_rich);
  ParallelFor(rich, [&](int k) { robust(work.size() - 1 - static_cast<size_t>(k), from); });

  // Common outliers: observations that even the best-fitting model (lowest robust noise) does not explain.
  int best = -1;
  double best_sigma = kInf;
  for (size_t i = 0; i < work.size(); ++i) {
    const double s = MadSigma(work[i].robust_residuals);
    if (work[i].robust_ok && s < best_sigma) best_sigma = s, best = static_cast<int>(i);
  }
  std::vector<bool> inlier(setup.obs.size(), true);
  if (best >= 0) {
    const double threshold = std::max(options.outlier_sigmas * best_sigma, options.outlier_min_px);
    const auto& r = work[static_cast<size_t>(best)].robust_residuals;
    for (size_t i = 0; i < r.size(); ++i) inlier[i] = r[i].allFinite() && r[i].norm() <= threshold;
  }

  // Pass 2: each candidate's final fit, budget rows and held-out error, independent of the others: on all cores,
  // the richest (slowest) first.
  result.candidates.resize(work.size());
  ParallelFor(static_cast<int>(work.size()), [&](int k) {
    const size_t i = work.size() - 1 - static_cast<size_t>(k);
    const Stopwatch watch;
    ModelFit& fit = result.candidates[i];
    fit.model = ScreenModelName(work[i].kind);
    FitFinal(setup, work[i], inlier, &fit);
    fit.heldout_rms_px = HeldOut(setup, work[i], inlier, fit, false);
    if (options.heldout_strips && work[i].kind != ScreenModelKind::kCylinderDeviation) {
      fit.heldout_strips_px = HeldOut(setup, work[i], inlier, fit, true);
    }
    fit.time_ms = time_ms[i] + watch.Ms();
  });
  result.detection_noise_px = DetectionSigma(options);
  result.detection_noise_assumed = !(options.detection_noise_px > 0);
  result.adequacy_limit_px = AdequacyLimit(options);
  AdjustForLensField(options, camera.width, work, &result);
  Choose(options, &result);
  CompleteFits(setup, work, &result);
  result.noise_px = result.Chosen().noise_px;
  if (!result.Chosen().adequate) {
    result.status = "inadequate";
    result.warnings.push_back(InadequacyWarning(photos, result));
  }
  for (size_t i = 0; i < result.candidates.size(); ++i) {
    const ModelFit& c = result.candidates[i];
    if (!c.ill_conditioned) continue;
    std::string note = c.condition_note;
    while (!note.empty() && note.back() == ' ') note.pop_back();
    result.warnings.push_back(c.model + ": ill-conditioned: " + note);
    if ((static_cast<int>(i) == result.chosen || c.model == "cylinder") && result.status == "ok") {
      result.status = "ill_conditioned";
    }
  }
  if (std::optional<std::string> w = PlausibilityWarning(nominal, result)) result.warnings.push_back(*w);
  Deviations(setup, work[static_cast<size_t>(result.chosen)], &result);

  result.assumptions.push_back(fmt::format(
      "pixel pitch fixed from the spec: {} x {} px over {:.2f} x {:.2f} mm ({:.4f} mm/px); scale is not observable "
      "from photos, so radius and distances scale with it",
      nominal.width_px, nominal.height_px, nominal.width_mm, nominal.height_mm, nominal.pixel_pitch_mm()));
  result.assumptions.push_back(
      options.fit_intrinsics
          ? fmt::format("lens intrinsics ({}) estimated jointly with the poses and the screen, seeded from the given "
                        "model; their uncertainty is in the joint covariance",
                        camera.lensmodel)
      : options.intrinsics_covariance.size() > 0
          ? fmt::format("lens model fixed in the fit: {} as calibrated; its calibration covariance ({}) is propagated "
                        "into the sigmas (uncertainty budget, lens calibration row)",
                        camera.lensmodel, options.intrinsics_covariance_source)
          : fmt::format("lens model fixed: {} as calibrated; {}", camera.lensmodel, options.lens_exact_note));
  result.assumptions.push_back(fmt::format(
      "sigmas and intervals are the combined standard uncertainty of the budget (detection noise, detector "
      "systematic, lens calibration, pixel pitch); the 95% interval uses Student's t at the effective degrees of "
      "freedom (Welch-Satterthwaite)"));
  result.assumptions.push_back(
      "detection noise isotropic and Gaussian; sigmas scaled by the measured residual noise (reduced chi-square)");
  result.assumptions.push_back(
      result.detection_noise_assumed
          ? fmt::format("detection noise not measured: each model's fit was tested against an assumed {:.3f} px per "
                        "coordinate (--expected-noise); adequacy is only as good as that guess",
                        result.detection_noise_px)
          : fmt::format("each model's fit tested against the measured detection noise, {:.3f} px per coordinate",
                        result.detection_noise_px));
  result.assumptions.push_back(
      "deviations are along the surface normal; displacements within the surface are not modelled");
  if (std::find(kinds.begin(), kinds.end(), ScreenModelKind::kCylinderDeviation) != kinds.end()) {
    result.assumptions.push_back(fmt::format(
        "deviation field: {} x {} cubic B-splines with the rigid and radius modes removed (zero mean, no tilt, no "
        "curvature relative to the fitted cylinder) and a {:g} mm prior",
        options.deviation_nu, options.deviation_nv, options.deviation_prior_mm));
  }
  return result;
}

double ChiSquareUpperTail(double chi2, double dof) {
  if (!(dof > 0) || !(chi2 >= 0)) return kNaN;
  if (chi2 == 0) return 1;
  if (std::isinf(chi2)) return 0;
  // Q(a, x) = Gamma(a, x) / Gamma(a), a = dof/2, x = chi2/2 (Numerical Recipes 6.2): below x = a + 1 the series
  // of P = 1 - Q (Q > 0.08 there for every a, so 1 - P loses at most a digit); above, Q's continued fraction
  // (modified Lentz), accurate far into the tail. Both converge in O(sqrt(a)) terms.
  const double a = 0.5 * dof, x = 0.5 * chi2;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  constexpr int kMaxTerms = 10000000;
  constexpr double kEps = 1e-16, kTiny = 1e-300;
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < kMaxTerms; ++n) {
      term *= x / (a + n);
      sum += term;
      if (term < sum * kEps) break;
    }
    return std::clamp(1 - sum * std::exp(log_prefix), 0.0, 1.0);
  }
  double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
  for (int i = 1; i < kMaxTerms; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < kEps) break;
  }
  return std::clamp(std::exp(log_prefix) * h, 0.0, 1.0);
}

double RadiusCramerRaoBoundMm(const Monitor& true_monitor, const CameraModel& camera,
                              const std::vector<Pose>& centre_from_cams,
                              const std::vector<std::vector<Eigen::Vector2d>>& display_px, double sigma_px) {
  true_monitor.Check("true monitor");
  camera.Check("camera model");
  if (true_monitor.is_flat()) {
    throw Error("Cramer-Rao bound", "the true monitor is flat: the radius is infinite", "give a curved monitor");
  }
  if (centre_from_cams.size() != display_px.size() || centre_from_cams.empty()) {
    throw Error("Cramer-Rao bound", "give one pose per list of display positions", "");
  }
  State st;
  st.core = {true_monitor.curvature_per_mm};
  for (const Pose& p : centre_from_cams) {
    const Eigen::Quaterniond& q = p.rotation;
    st.poses.push_back({q.x(), q.y(), q.z(), q.w(), p.translation.x(), p.translation.y(), p.translation.z()});
  }
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> manifold{
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<3>()};
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem pr(po);
  for (size_t p = 0; p < centre_from_cams.size(); ++p) {
    for (const Eigen::Vector2d& px : display_px[p]) {
      const Eigen::Vector2d uv = UvFromDisplayPx(true_monitor, px);
      const double s = 0.5 * uv.x() * true_monitor.width_mm, y = -0.5 * uv.y() * true_monitor.height_mm;
      // The detection is the noiseless prediction: the Jacobian does not depend on it.
      pr.AddResidualBlock(new ReprojectionCost(&camera, ScreenModelKind::kCylinder, s, y, 0.5 * true_monitor.width_mm,
                                               Eigen::Vector2d::Zero()),
                          nullptr, {st.poses[p].data(), st.core.data()});
    }
    pr.SetManifold(st.poses[p].data(), &manifold);
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  const std::vector<std::pair<const double*, const double*>> pairs = {{st.core.data(), st.core.data()}};
  if (!cov.Compute(pairs, &pr)) {
    throw Error("Cramer-Rao bound", "the radius is not observable in this configuration (singular Fisher matrix)",
                "add features or photos from other positions");
  }
  double ckk = 0;
  cov.GetCovarianceBlock(st.core.data(), st.core.data(), &ckk);
  const double k = true_monitor.curvature_per_mm;
  return sigma_px * std::sqrt(ckk) / (k * k);
}

}  // namespace curvecheck
