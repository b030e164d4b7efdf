// result.json of an analysis (analysis/pipeline.h ResultJson): the photos, their detections and verifications,
// the chosen fit with its uncertainty budget and every candidate, the features. Kept apart from the pipeline that
// computes what it writes.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "analysis/pipeline.h"
#include "core/monitor_json.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {
nlohmann::json Vec(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }
nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
// JSON has no NaN or infinity: those become null.
nlohmann::json Num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
constexpr double kNaNJson = std::numeric_limits<double>::quiet_NaN();

nlohmann::json VerificationJson(const Verification& v) {
  nlohmann::json j = {{"rms_px", v.rms_px},
                      {"max_px", v.max_px},
                      {"rms_arcmin", v.rms_arcmin},
                      {"max_arcmin", v.max_arcmin},
                      {"rms_display_px", Num(v.rms_display_px)},
                      {"max_display_px", Num(v.max_display_px)},
                      {"p95_display_px", Num(v.p95_display_px)},
                      {"tolerance_display_px", v.tolerance_display_px},
                      {"pass", v.pass},
                      {"features", v.features.size()}};
  if (v.failure.empty()) {
    j["verdict"] = VerdictName(v.verdict);
    j["decision_rule"] =
        "pass when e + U <= T, fail when e - U > T, otherwise inconclusive (ISO 14253-1 guard band); e: 95th "
        "percentile over the features of the correction-error field's length (the smooth part of the residuals), "
        "U: its expanded uncertainty (simultaneous 95% band), T: the tolerance";
    j["error_p95_display_px"] = Num(v.error_p95_display_px);
    j["expanded_uncertainty_display_px"] = Num(v.expanded_uncertainty_display_px);
    j["coverage_factor"] = Num(v.coverage_factor);
    j["uncertainty_budget"] = {
        {"field_band_display_px", Num(v.field_band_display_px)},
        {"detector_systematic_display_px", Num(v.systematic_display_px)},
        {"note", "U = sqrt(field_band^2 + detector_systematic^2); field_band: simultaneous 95% band of the "
                 "correction-error field from the measured scatter (random); detector_systematic: 2 x VerifyOptions::detector_systematic_px "
                 "(0.05 camera px by default: the detector's bias, pixel-locking and small squares) through the "
                 "display px per camera px"}};
    j["tolerance_ratio"] = Num(v.tolerance_ratio);
    j["noise_px"] = Num(v.noise_px);
    j["display_px_per_camera_px"] = Num(v.display_px_per_camera_px);
    j["field_degree"] = v.field_degree;
    j["field_outliers"] = v.field_outliers;
    if (v.pixel_locking.estimated) {
      const PixelLocking& pl = v.pixel_locking;
      const Eigen::Vector4d sigma = pl.covariance.diagonal().cwiseMax(0).cwiseSqrt();
      j["pixel_locking"] = {
          {"model", "detected - true = a sin(2 pi q) + b cos(2 pi q) per coordinate, q the detected camera px"},
          {"a_x_px", Num(pl.coefficients(0))}, {"b_x_px", Num(pl.coefficients(1))},
          {"a_y_px", Num(pl.coefficients(2))}, {"b_y_px", Num(pl.coefficients(3))},
          {"sigma_px", {Num(sigma(0)), Num(sigma(1)), Num(sigma(2)), Num(sigma(3))}},
          {"amplitude_px", {Num(pl.Amplitude().x()), Num(pl.Amplitude().y())}},
          {"noise_without_px", Num(pl.noise_px)},
          {"note", "fitted beside the correction-error field; removed from the detections before the screen fit only with "
                   "analyze --correct-pixel-locking"}};
    }
    j["reason"] = v.verdict_reason;
    if (!v.advice.empty()) j["advice"] = v.advice;
  } else {
    j["verdict"] = nullptr;
  }
  if (!v.failure.empty()) j["failure"] = v.failure;
  return j;
}

nlohmann::json ModelFitJson(const ModelFit& f) {
  nlohmann::json j = {{"model", f.model},
                      {"parameters", f.parameters},
                      {"chi2", Num(f.chi2)},
                      {"dof", f.dof},
                      {"chi2_p_value", Num(f.chi2_p_value)},
                      {"noise_ratio", Num(f.noise_ratio)},
                      {"adequate", f.adequate},
                      {"rms_px", f.rms_px},
                      {"noise_px", f.noise_px},
                      {"bic", f.bic},
                      {"heldout_rms_px", Num(f.heldout_rms_px)},
                      {"heldout_strips_px", Num(f.heldout_strips_px)},
                      {"vetoed", f.vetoed},
                      {"bic_white", Num(f.bic_white)},
                      {"lens_field_rss_px2", Num(f.lens_field_rss_px2)},
                      {"heldout_adjusted_px", Num(f.heldout_adjusted_px)},
                      {"curvature_per_mm", f.curvature_per_mm},
                      {"curvature_sigma_per_mm", f.curvature_sigma_per_mm},
                      {"radius_mm", f.radius_mm ? nlohmann::json(*f.radius_mm) : nlohmann::json(nullptr)},
                      {"radius_sigma_mm", f.radius_sigma_mm ? nlohmann::json(*f.radius_sigma_mm) : nlohmann::json(nullptr)},
                      {"radius_ci95_mm", {Num(f.radius_ci95_mm[0]), Num(f.radius_ci95_mm[1])}},
                      {"radius_ci68_mm", {Num(f.radius_ci68_mm[0]), Num(f.radius_ci68_mm[1])}},
                      {"converged", f.converged},
                      {"ill_conditioned", f.ill_conditioned},
                      {"time_ms", f.time_ms}};
  if (!f.radius_mm) j["radius_lower_bound_mm"] = f.radius_lower_bound_mm;
  // measured: a number; unobservable: ill-conditioned, no number; lower_bound: flat is consistent, the nominal
  // is not; flat_model: the model has no radius.
  j["radius_status"] = f.model == "flat"  ? "flat_model"
                       : f.radius_mm      ? "measured"
                       : f.ill_conditioned ? "unobservable"
                                           : "lower_bound";
  if (!f.condition_note.empty()) j["condition_note"] = f.condition_note;
  if (!f.adequacy_note.empty()) j["adequacy_note"] = f.adequacy_note;
  nlohmann::json extra = nlohmann::json::object();
  for (const auto& [name, value] : f.extra) extra[name] = {{"value", value.first}, {"sigma", value.second}};
  j["extra"] = extra;
  return j;
}

// One budget (UncertaintyBudget) for one quantity: per row its standard uncertainty, picked by `u` from the row.
// The 95% and 68% intervals with their coverage factors.
struct Intervals {
  std::array<double, 2> at95, at68;
  double factor95, factor68;
  // value +- factor u for both.
  static Intervals Symmetric(double value, double u, double factor95, double factor68) {
    return {{value - factor95 * u, value + factor95 * u}, {value - factor68 * u, value + factor68 * u}, factor95,
            factor68};
  }
};

nlohmann::json BudgetRowsJson(const UncertaintyBudget& b, const std::function<double(const BudgetComponent&)>& u,
                              const std::string& unit_suffix, double value, const Intervals& interval) {
  nlohmann::json rows = nlohmann::json::array();
  size_t dominant = 0;
  for (size_t i = 0; i < b.components.size(); ++i) {
    const BudgetComponent& c = b.components[i];
    if (u(c) > u(b.components[dominant])) dominant = i;
    rows.push_back({{"name", c.name},
                    {"type", c.type},
                    {"standard_uncertainty" + unit_suffix, Num(u(c))},
                    {"dof", Num(c.dof)},
                    {"distribution", RowDistributionName(c.distribution)},
                    {"source", c.source},
                    {"assumption", c.assumption}});
  }
  return {{"value" + unit_suffix, Num(value)},
          {"components", rows},
          {"combined_standard_uncertainty" + unit_suffix, Num(u(b.combined))},
          {"coverage_factor", Num(interval.factor95)},
          {"coverage_probability", b.coverage_probability},
          {"effective_dof", Num(b.effective_dof)},
          {"interval95" + unit_suffix, {Num(interval.at95[0]), Num(interval.at95[1])}},
          {"coverage_factor68", Num(interval.factor68)},
          {"interval68" + unit_suffix, {Num(interval.at68[0]), Num(interval.at68[1])}},
          {"dominant", b.components.empty() ? std::string() : b.components[dominant].name}};
}

// fit.uncertainty_budget (metrology.md section 1): the radius at the top, the curvature and the first camera's
// position (axis frame, per axis) below it, and the detector-systematic estimate.
nlohmann::json BudgetJson(const ModelFit& f, const std::string& first_photo) {
  const UncertaintyBudget& b = f.budget;
  if (!b.computed) return {{"computed", false}, {"note", b.note}};
  const double kc = b.coverage_factor, kc68 = b.coverage_factor68;
  nlohmann::json j = BudgetRowsJson(b, [](const BudgetComponent& c) { return c.radius_mm; }, "_mm",
                                    f.radius_mm.value_or(kNaNJson),
                                    {f.radius_ci95_mm, f.radius_ci68_mm, kc, kc68});
  j["quantity"] = "radius R (mm); rows u(R) = u(k)/k^2; null when the radius is not a number";
  j["unit"] = "mm";
  j["interval_note"] = fmt::format(
      "formed on the curvature, k +- {:.3f} u_c(k), and inverted to R. Coverage factor for {:g}%: the normal rows "
      "as Student's t at their Welch-Satterthwaite degrees of freedom (type B rows: infinite), convolved with the "
      "rectangular row (the pixel pitch's tolerance) exactly; 1.96 for normal rows alone, 1.645 for the "
      "rectangular alone. Each quantity (curvature, each camera coordinate) has its own factor from its own rows. "
      "The 68% interval likewise (factor 1 for normal rows alone, 1.18 for the rectangular alone)",
      kc, 100 * b.coverage_probability);
  const double k = f.curvature_per_mm, uk = b.combined.curvature_per_mm;
  j["curvature"] = BudgetRowsJson(b, [](const BudgetComponent& c) { return c.curvature_per_mm; }, "_per_mm", k,
                                  Intervals::Symmetric(k, uk, kc, kc68));
  j["curvature"]["quantity"] = "curvature k = 1/R (mean over the width for varying curvature)";
  j["curvature"]["unit"] = "1/mm";
  if (!f.cameras.empty()) {
    const CameraEstimate& cam = f.cameras[0];
    nlohmann::json pos = {{"photo", first_photo},
                          {"frame", "axis (position_in_axis_mm: origin on the fitted axis; the centre frame when "
                                    "the radius is not a number)"}};
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const double v = cam.position_in_screen_mm[a], ua = b.combined.position_in_axis_mm[a];
      nlohmann::json row = BudgetRowsJson(
          b, [a](const BudgetComponent& c) { return c.position_in_axis_mm[a]; }, "_mm", v,
          Intervals::Symmetric(v, ua, b.position_factor.axis[a], b.position_factor68.axis[a]));
      row["quantity"] = fmt::format("first camera position {} (axis frame)", axes[a]);
      row["unit"] = "mm";
      pos[axes[a]] = row;
    }
    j["camera_position"] = pos;
  }
  const UncertaintyBudget::NoiseIndependence& ni = b.noise_independence;
  const auto matrix = [](const Eigen::Matrix2d& m) {  // rows x, y; columns along the screen's rows, its columns
    return nlohmann::json{{"x", {Num(m(0, 0)), Num(m(0, 1))}}, {"y", {Num(m(1, 0)), Num(m(1, 1))}}};
  };
  j["detection_noise_independence"] = {
      {"tested", ni.tested},
      {"independent", ni.tested ? nlohmann::json(ni.independent) : nlohmann::json(nullptr)},
      {"pairs", {{"along_rows", ni.pairs[0]}, {"along_columns", ni.pairs[1]}}},
      {"correlation", matrix(ni.correlation)},
      {"correlation_if_independent", matrix(ni.null_correlation)},
      {"z", matrix(ni.z)},
      {"z_threshold", UncertaintyBudget::kNoiseIndependenceZ},
      {"summary", ni.summary},
      {"method", "a test of the detection-noise row's assumption, not used by it: pairs of lattice neighbours on the "
                 "screen (the white scatter's triples' steps along the screen's rows and along its columns; "
                 "correlation, its expectation and z: rows x, y camera px, columns along the rows, along the "
                 "columns); r the correlation of the residuals without the pixel-locking signature, r0 its "
                 "expectation were the errors independent (-mean H_ab / mean (1 - H_ii), H the fit's hat matrix), "
                 "z = (r - r0) sqrt(pairs); independent when every measured |z| < z_threshold"}};
  j["detector_systematic"] = {
      {"pixel_locking_amplitude_px", Vec(Eigen::Vector2d(b.pixel_locking.amplitude_px.col(0)))},
      {"pixel_locking_sigma_px", Vec(Eigen::Vector2d(b.pixel_locking.sigma_px.col(0)))},
      {"pixel_locking_period2_amplitude_px", Vec(Eigen::Vector2d(b.pixel_locking.amplitude_px.col(1)))},
      {"pixel_locking_period2_sigma_px", Vec(Eigen::Vector2d(b.pixel_locking.sigma_px.col(1)))},
      {"pixel_locking_observations", b.pixel_locking.observations},
      {"tag_border_shift_px", b.pixel_locking.tag_border_corners > 0 ? Vec(b.pixel_locking.tag_border_shift_px)
                                                                       : nlohmann::json(nullptr)},
      {"tag_border_shift_sigma_px", b.pixel_locking.tag_border_corners > 0
                                        ? Vec(b.pixel_locking.tag_border_shift_sigma_px)
                                        : nlohmann::json(nullptr)},
      {"tag_border_corners", b.pixel_locking.tag_border_corners},
      {"polarity_px", b.pixel_locking.polarity_corners > 0 ? Vec(b.pixel_locking.polarity_px) : nlohmann::json(nullptr)},
      {"polarity_sigma_px", b.pixel_locking.polarity_corners > 0 ? Vec(b.pixel_locking.polarity_sigma_px)
                                                                 : nlohmann::json(nullptr)},
      {"polarity_corners", b.pixel_locking.polarity_corners},
      {"noise_without_signature_px", Num(b.pixel_locking.noise_px)},
      {"method", "per coordinate and period (1 px; 2 px, a colour filter array's) the bias a sin 2 pi phi + b cos "
                 "2 pi phi, phi the phase of the fit's prediction in the period; the coefficients fitted to the "
                 "fit's residuals (detected - predicted) on the shapes' refit projections (I - J (J^T J)^+ J^T) sin, "
                 "cos, so that the part the fit absorbed counts; amplitude = sqrt(a^2 + b^2). The curvature (so the "
                 "radius) and the camera positions are corrected for the fitted signature by -G S b (the linearized "
                 "fit with the coefficients as nuisance parameters); the correction's uncertainty is in this row. "
                 "With tags, two more coefficients in the same fit and correction: the shift of the tags' black "
                 "border edges in x and y (px, outward), each corner moved by sqrt(2) times it along its tag's "
                 "diagonal (tag_border_shift_px). Also in the same fit, prior and correction: per coordinate the 2 px "
                 "period's cross terms (sin, cos of the other coordinate's phase and the four products of the two "
                 "phases' sin and cos: the error as a function of the position in a colour filter array's 2 x 2 "
                 "cell), and on a checkerboard the corner's polarity p = +-1 (the parity of its row + column: the two "
                 "mirror-image saddles alternate) times 1 and the two phases' sin and cos (polarity_px: the "
                 "coefficients of p alone, the polarity's error at the cell's mean)"},
      {"correction",
       {{"curvature_per_mm", b.pixel_locking_correction_curvature_per_mm},
        {"radius_mm", Num(f.radius_mm ? *f.radius_mm - 1 / (f.curvature_per_mm -
                                                                  b.pixel_locking_correction_curvature_per_mm)
                                      : kNaNJson)},
        {"curvature_sigma_per_mm", Num(b.pixel_locking_share_curvature_per_mm)},
        {"radius_sigma_mm", Num(f.radius_mm ? b.pixel_locking_share_curvature_per_mm /
                                                  (f.curvature_per_mm * f.curvature_per_mm)
                                            : kNaNJson)},
        {"first_camera_position_in_centre_mm", Vec(b.pixel_locking_correction_position_mm)},
        {"first_camera_position_sigma_in_centre_mm", Vec(b.pixel_locking_correction_sigma_position_mm)},
        {"frame", "centre (origin at the screen's centre, the same frame as the camera's position_in_centre_mm)"},
        {"note", "added to the fit's values (reported ones include it); each sigma is the correction's standard "
                 "uncertainty, a part of this row (not an extra one); the fitted surface, the rotations and the "
                 "deviations are the uncorrected fit's"}}},
      {"bound_px", b.systematic_bound_px},
      {"white_scatter_px", Num(b.white_scatter_px)},
      {"white_scatter_u_difference_px2", Num(b.white_scatter_u_difference_px2)},
      {"white_scatter_triples", b.white_scatter_triples},
      {"smooth_fields_curvature_per_mm", Num(b.smooth_share_curvature_per_mm)},
      {"pixel_locking_correction_sigma_curvature_per_mm", Num(b.pixel_locking_share_curvature_per_mm)},
      {"bound_reason", b.systematic_bound_reason}};
  j["lens_model_misfit"] = {
      {"neighbour_pairs", b.misfit_pairs},
      {"statistic_px2", Num(b.misfit_statistic_px2)},
      {"noise_share_px2", Num(b.misfit_noise_share_px2)},
      {"kappa", Num(b.misfit_kappa)},
      {"estimate_px", Num(b.misfit_estimate_px)},
      {"bound_px", Num(b.misfit_bound_px)},
      {"method", "each detection paired with its nearest neighbour in the same photo; statistic = mean of r_i . r_j "
                 "/ 2 over the pairs; RMS = sqrt((statistic - noise share) / kappa), kappa the share a unit-RMS "
                 "field of the assumed family (Legendre, the model choice's) leaves after the fit; bound adds 2 "
                 "sigma of the statistic under noise"},
      {"correlation",
       {{"feature_spacing_px", Num(b.misfit_spacing_px)},
        {"length_px", Num(b.misfit_length_px)},
        {"variance_px2", Num(b.misfit_variance_px2)},
        {"variance_sd_px2", Num(b.misfit_variance_sd_px2)},
        {"rms_px", Num(std::sqrt(std::max(0.0, b.misfit_variance_px2)))},
        {"weighted_chi2", Num(b.misfit_fit_chi2)},
        {"components", [&] {
           nlohmann::json a = nlohmann::json::array();
           for (const UncertaintyBudget::FieldComponent& component : b.misfit_components) {
             const bool ring = component.family == UncertaintyBudget::FieldFamily::kRing;
             a.push_back({{"family", ring ? "ring" : "gaussian"},
                          {ring ? "period_px" : "length_px", component.length_px},
                          {"variance_px2", component.variance_px2},
                          {"variance_sd_px2", component.variance_sd_px2}});
           }
           return a;
         }()},
        {"lags", [&] {
           nlohmann::json a = nlohmann::json::array();
           for (const UncertaintyBudget::Lag& l : b.misfit_lags) {
             a.push_back({{"lag_spacings", l.lag_spacings},
                          {"pairs", l.pairs},
                          {"statistic_px2", l.statistic_px2},
                          {"noise_share_px2", l.noise_share_px2},
                          {"field_share_px2", l.field_share_px2}});
           }
           return a;
         }()},
        {"method", "what the row propagates: mean r_a . r_b / 2 over pairs in the same photo at 0-1.5, 1.5-2.5, "
                   "2.5-3.5, 3.5-5, 5-7, 7-10, 10-14, 14-20, 20-28 feature spacings, fitted by up to two stationary "
                   "Gaussian fields (family gaussian: covariance s^2 exp(-d^2 / 2 L^2), L of 1-32 feature spacings) "
                   "and one ring field (family ring: covariance s^2 J0(2 pi d / P), P of 3-24 spacings, a band-pass "
                   "beat whose correlation changes sign) after the fit's linearized refit plus the noise's share; "
                   "the combination of the smallest weighted misfit + 2 per component (AIC)"}}},
      {"row_basis", b.misfit_row_basis},
      {"measured_curvature_per_mm", Num(b.measured_misfit_share_curvature_per_mm)},
      {"measured_curvature_sd_per_mm", Num(b.measured_misfit_share_sd_curvature_per_mm)},
      {"stated_curvature_per_mm", Num(b.stated_misfit_share_curvature_per_mm)},
      {"row_rule", "u(k) of the field measured from the residuals (measured_curvature_per_mm) and of the calibration's "
                   "stated misfit field when one is given (stated_curvature_per_mm: calibrate's measurement in the "
                   "intrinsics covariance sidecar, or analyze --lens-misfit); the row is the calibration's unless the "
                   "measured u(k)^2 exceeds the stated one by more than 1.645 of its own standard uncertainty (a "
                   "one-sided 5% test; row_basis residuals or calibration)"}};
  j["correlations"] = "rows are independent of one another and combined in quadrature; within a row the curvature "
                      "and the camera positions are correlated (their covariance is carried into the axis-frame z)";
  if (!b.note.empty()) j["note"] = b.note;
  return j;
}


}  // namespace

nlohmann::json ResultJson(const AnalysisResult& r, const std::string& command_line) {
  nlohmann::json j;
  j["format"] = "curvecheck.result/1";
  j["command"] = command_line;

  nlohmann::json photos = nlohmann::json::array();
  for (const PhotoAnalysis& p : r.photos) {
    nlohmann::json e = {{"name", p.name},
                        {"photo", p.input.photo.string()},
                        {"pattern", p.input.pattern.string()},
                        {"status", p.used ? "used" : "rejected"}};
    if (!p.used) e["reason"] = p.rejected;
    if (p.duplicate_of >= 0) e["duplicate_of"] = r.photos[static_cast<size_t>(p.duplicate_of)].name;
    if (!p.detection.detector.empty()) {
      int flagged = 0;
      for (const DetectedFeature& f : p.detection.features) flagged += f.flag.empty() ? 0 : 1;
      e["detection"] = {{"detector", p.detection.detector},
                        {"features", p.detection.features.size()},
                        {"flagged", flagged},
                        {"notes", p.detection.notes},
                        {"time_ms", p.detection.time_ms}};
      if (p.gray_conversion.colour) {  // core/image_decode.h ColourPhotoToGray
        e["detection"]["gray"] = {{"conversion", p.gray_conversion.channel_mean ? "channel mean" : "luma"},
                                  {"chroma_texture", p.gray_conversion.chroma_texture},
                                  {"chroma_texture_limit", kColourAliasingLimit},
                                  {"bright_fraction", p.gray_conversion.bright_fraction}};
      }
      const MoireMeasure& m = p.detection.moire;  // detect/moire.h; periods and sigmas in camera px
      e["detection"]["moire"] = {{"patches", m.patches},         {"present", m.present},
                                 {"period_px", m.period_px},     {"contrast", m.contrast},
                                 {"peak_to_floor", m.peak_to_floor}, {"display_pitch_px", m.display_pitch_px},
                                 {"filter_sigma_px", m.filter_sigma_px}, {"texture", m.texture},
                                 {"texture_sigma_px", m.texture_sigma_px}};
      e["detection"]["moire"]["gap_deficit"] = m.gap_deficit >= 0 ? nlohmann::json(m.gap_deficit) : nlohmann::json();
      e["detection"]["moire"]["photo_gap_deficit"] =
          m.photo_gap_deficit >= 0 ? nlohmann::json(m.photo_gap_deficit) : nlohmann::json();
      e["detection"]["moire"]["gap_deficit_limit"] = kGapDeficitLimit;
      e["detection"]["moire"]["found_on_closing_px"] = m.found_on_closing_px;
      e["detection"]["moire"]["refined_on_closed_patches"] = m.refined_on_closed_patches;
      // detect.h RefinementNoise: the photo's noise (gray levels of its depth) and the refined corners' response
      // to it (px per coordinate), the random part the detector-systematic row's smooth bound leaves out.
      // detect.h: the tags' border shift in the code values as they are, and the tone power that undid it.
      const auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
      e["detection"]["tag_border_shift_px"] = finite_or_null(p.detection.tag_border_shift_px);
      e["detection"]["tag_tone_gamma"] = finite_or_null(p.detection.tag_tone_gamma);
      const RefinementNoise& rn = p.detection.refinement_noise;
      e["detection"]["refinement_noise"] =
          rn.measured ? nlohmann::json{{"basis", rn.basis},
                                       {"black_sd", rn.black_sd},
                                       {"white_sd", rn.white_sd},
                                       {"black_level", rn.black_level},
                                       {"white_level", rn.white_level},
                                       {"correlation_lag1", rn.correlation_lag1},
                                       {"black_interiors", rn.black_patches},
                                       {"white_interiors", rn.white_patches},
                                       {"draws", rn.draws},
                                       {"corners", rn.corners},
                                       {"response_px", rn.response_px},
                                       {"response_u_px", rn.response_u_px}}
                      : nlohmann::json();
    }
    if (p.used) e["verification"] = VerificationJson(p.verification);
    photos.push_back(e);
  }
  j["inputs"] = {{"camera",
                  {{"path", r.camera_path.string()},
                   {"lensmodel", r.camera.lensmodel},
                   {"imagersize", {r.camera.width, r.camera.height}}}},
                 {"monitor", MonitorToJson(r.monitor)},
                 {"photos", photos}};

  j["verification"] = VerificationJson(r.verification);
  if (r.UsedPhotos() == 0) j["verification"]["failure"] = "no usable photo";

  // Per-feature fit residuals and deviations, keyed by (fit photo index, id).
  std::map<std::pair<int, std::string>, std::pair<Eigen::Vector2d, bool>> fit_residual;
  std::map<std::pair<int, std::string>, const FeatureDeviation*> deviation;
  if (r.fit) {
    const ScreenFitResult& fit = *r.fit;
    const ModelFit& chosen = fit.Chosen();
    for (const PhotoAnalysis& p : r.photos) {
      if (p.fit_index < 0) continue;
      const auto& res = chosen.residual_px[static_cast<size_t>(p.fit_index)];
      const auto& out = chosen.outlier[static_cast<size_t>(p.fit_index)];
      for (size_t k = 0; k < p.fit_ids.size() && k < res.size(); ++k) {
        fit_residual[{p.fit_index, p.fit_ids[k]}] = {res[k], k < out.size() && out[k]};
      }
    }
    for (const FeatureDeviation& d : fit.deviations) deviation[{d.photo, d.id}] = &d;

    nlohmann::json cameras = nlohmann::json::array();
    for (const PhotoAnalysis& p : r.photos) {
      if (p.fit_index < 0 || static_cast<size_t>(p.fit_index) >= chosen.cameras.size()) continue;
      const CameraEstimate& c = chosen.cameras[static_cast<size_t>(p.fit_index)];
      // Each position with the sigma of that position in that frame: the axis frame (origin on the fitted
      // cylinder's axis: moves with the radius) and the centre frame (origin at the screen centre).
      cameras.push_back({{"photo", p.name},
                         {"position_mm", Vec(c.position_in_screen_mm)},
                         {"position_sigma_mm", Vec(c.position_in_screen_sigma_mm)},
                         {"position_in_axis_mm", Vec(c.position_in_screen_mm)},
                         {"position_in_axis_sigma_mm", Vec(c.position_in_screen_sigma_mm)},
                         {"position_in_centre_mm", Vec(c.position_in_centre_mm)},
                         {"position_in_centre_sigma_mm", Vec(c.position_in_centre_sigma_mm)},
                         {"stated_viewpoint_mm", Vec(r.patterns[static_cast<size_t>(&p - r.photos.data())].viewpoint_in_screen)}});
    }
    nlohmann::json f = ModelFitJson(chosen);
    f["camera_position_mm"] = cameras.empty() ? nlohmann::json(nullptr) : cameras[0]["position_mm"];
    f["camera_position_sigma_mm"] = cameras.empty() ? nlohmann::json(nullptr) : cameras[0]["position_sigma_mm"];
    f["cameras"] = cameras;
    f["curvature_noise_sigma_per_mm"] = Num(chosen.curvature_noise_sigma_per_mm);
    f["radius_noise_sigma_mm"] =
        chosen.radius_mm ? Num(chosen.curvature_noise_sigma_per_mm / (chosen.curvature_per_mm * chosen.curvature_per_mm))
                         : nlohmann::json(nullptr);
    f["uncertainty_budget"] =
        BudgetJson(chosen, cameras.empty() ? std::string() : cameras[0]["photo"].get<std::string>());
    f["camera_position_frame"] = "axis: origin on the fitted cylinder's axis at the screen's vertical centre (the "
                                 "centre frame when the radius is not a number); cameras[] have both frames";
    f["status"] = fit.status;
    f["detection_noise_px"] = Num(fit.detection_noise_px);
    f["detection_noise_assumed"] = fit.detection_noise_assumed;
    f["adequacy_limit_px"] = Num(fit.adequacy_limit_px);
    f["lens_field_px"] = Num(fit.lens_field_px);
    f["warnings"] = fit.warnings;
    f["choice_reason"] = fit.choice_reason;
    f["assumptions"] = fit.assumptions;
    nlohmann::json candidates = nlohmann::json::array();
    for (size_t k = 0; k < fit.candidates.size(); ++k) {
      nlohmann::json c = ModelFitJson(fit.candidates[k]);
      c["chosen"] = static_cast<int>(k) == fit.chosen;
      candidates.push_back(c);
    }
    f["candidates"] = candidates;
    j["fit"] = f;

    nlohmann::json map_mm = nlohmann::json::array(), map_sigma = nlohmann::json::array();
    for (double v : fit.map_mm) map_mm.push_back(Num(v));
    for (double v : fit.map_sigma_mm) map_sigma.push_back(Num(v));
    j["deviations"] = {{"note", "displacement of the physical screen along the surface normal of the chosen model's "
                                "base surface, toward the viewer positive, mm; the map is a smoothing of the per-feature "
                                "values over (u, v) in [-1, 1] x [-1, 1] (row-major, u fastest, v from -1 at the top), "
                                "null where no feature supports it"},
                       {"map", {{"nu", fit.map_nu}, {"nv", fit.map_nv}, {"mm", map_mm}, {"sigma_mm", map_sigma}}}};
  } else {
    j["fit"] = {{"model", nullptr}, {"failure", r.fit_failure}};
  }

  nlohmann::json features = nlohmann::json::array();
  nlohmann::json fit_outliers = nlohmann::json::array();
  for (const PhotoAnalysis& p : r.photos) {
    if (!p.used) continue;
    std::map<std::string, const FeatureCheck*> checks;
    for (const FeatureCheck& c : p.verification.features) checks[c.id] = &c;
    for (const DetectedFeature& d : p.detection.features) {
      nlohmann::json e = {{"id", d.id}, {"photo", p.name}, {"detected_px", Vec(d.px)}, {"quality", d.quality}};
      if (!d.flag.empty()) e["flag"] = d.flag;
      const auto c = checks.find(d.id);
      if (c != checks.end()) {
        e["display_px"] = Vec(c->second->display_px);
        e["expected_px"] = Vec(c->second->expected_px);
        e["residual_px"] = Vec(c->second->residual_px);
        e["residual_display_px"] = {Num(c->second->residual_display_px.x()), Num(c->second->residual_display_px.y())};
        e["residual_display_sigma_px"] = {Num(c->second->residual_display_sigma_px.x()),
                                          Num(c->second->residual_display_sigma_px.y())};
        e["error_display_px"] = {Num(c->second->error_display_px.x()), Num(c->second->error_display_px.y())};
        e["error_display_sigma_px"] = {Num(c->second->error_display_sigma_px.x()),
                                       Num(c->second->error_display_sigma_px.y())};
        if (c->second->field_outlier) e["field_outlier"] = true;
        if (p.verification.pixel_locking.estimated) e["pixel_locking_px"] = Vec(c->second->pixel_locking_px);
        e["residual_arcmin"] = c->second->residual_arcmin;
      }
      const auto fr = fit_residual.find({p.fit_index, d.id});
      if (fr != fit_residual.end()) {
        e["fit_residual_px"] = Vec(fr->second.first);
        if (fr->second.second) {
          e["fit_outlier"] = true;
          fit_outliers.push_back({{"photo", p.name}, {"id", d.id}, {"residual_px", Vec(fr->second.first)}});
        }
      }
      const auto dv = deviation.find({p.fit_index, d.id});
      if (dv != deviation.end()) {
        e["deviation_mm"] = dv->second->normal_mm;
        e["deviation_sigma_mm"] = dv->second->sigma_mm;
      }
      features.push_back(e);
    }
  }
  if (r.fit) j["fit"]["outliers"] = fit_outliers;
  j["features"] = features;
  j["timing_ms"] = {{"total", r.total_ms}, {"fit", r.fit_ms}};
  return j;
}

}  // namespace curvecheck
