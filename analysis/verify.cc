#include "analysis/verify.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "analysis/error_field.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/stats.h"

namespace curvecheck {
namespace {

constexpr double kArcminPerRad = 60.0 * 180.0 / M_PI;

// Residual of one feature under the homography, in camera px:
//   r = q_detected - project(H m),  m = ((a - a0) / scale, (b - b0) / scale, 1),
// H with H(2, 2) = 1 (8 free entries; the pattern centre lies in front of the camera, so H(2, 2) != 0). The
// projection is mrcal's (any lens model), its gradient dq/dp from libmrcal, so dr/dH_ij = -dq/dp_i m_j.
class HomographyResidual : public ceres::SizedCostFunction<2, 8> {
 public:
  HomographyResidual(const CameraModel& camera, const Eigen::Vector2d& m, const Eigen::Vector2d& detected_px)
      : camera_(camera), m_(m.x(), m.y(), 1.0), detected_(detected_px) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Matrix3d h = FromParameters(parameters[0]);
    const Eigen::Vector3d p = h * m_;
    if (!(p.z() > 0)) return false;  // behind the camera: ask Ceres for a shorter step
    std::vector<Eigen::Matrix<double, 2, 3>> dq_dp;
    const Eigen::Vector2d q = ProjectPoints(camera_, {p}, jacobians ? &dq_dp : nullptr)[0];
    residuals[0] = detected_.x() - q.x();
    residuals[1] = detected_.y() - q.y();
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 2, 8, Eigen::RowMajor>> j(jacobians[0]);
      for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) {
          const int index = 3 * i + k;
          if (index == 8) continue;
          j.col(index) = -dq_dp[0].col(i) * m_(k);
        }
      }
    }
    return true;
  }

  static Eigen::Matrix3d FromParameters(const double* h8) {
    Eigen::Matrix3d h;
    h << h8[0], h8[1], h8[2], h8[3], h8[4], h8[5], h8[6], h8[7], 1.0;
    return h;
  }

 private:
  const CameraModel& camera_;
  Eigen::Vector3d m_;
  Eigen::Vector2d detected_;
};

// Direct linear transform from points m (centred pattern coordinates) to normalized camera coordinates n,
// both already of unit scale.
Eigen::Matrix3d Dlt(const std::vector<Eigen::Vector2d>& m, const std::vector<Eigen::Vector2d>& n) {
  Eigen::MatrixXd a(2 * m.size(), 9);
  for (size_t i = 0; i < m.size(); ++i) {
    const double x = m[i].x(), y = m[i].y(), u = n[i].x(), v = n[i].y();
    a.row(2 * i) << x, y, 1, 0, 0, 0, -u * x, -u * y, -u;
    a.row(2 * i + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y, -v;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d hm;
  hm << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  return hm;
}

double AngleRad(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

Eigen::Vector3d JsonVector3(const nlohmann::json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) {
    throw Error(where, fmt::format("pattern.plane.{} is missing or not an array of 3 numbers", key),
                "write pattern.json with `curvecheck render`");
  }
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!j[key][i].is_number()) {
      throw Error(where, fmt::format("pattern.plane.{}[{}] is not a number", key, i),
                  "write pattern.json with `curvecheck render`");
    }
    v(i) = j[key][i].get<double>();
  }
  return v;
}

// 95th percentile of the display-px residuals' lengths (nearest rank; NaN lengths count as infinite).
double Percentile95Length(const std::vector<FeatureCheck>& features) {
  if (features.empty()) return 0;
  std::vector<double> lengths;
  for (const FeatureCheck& c : features) {
    const double l = c.residual_display_px.norm();
    lengths.push_back(std::isnan(l) ? std::numeric_limits<double>::infinity() : l);
  }
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * static_cast<double>(lengths.size()))) - 1;
  std::nth_element(lengths.begin(), lengths.begin() + static_cast<std::ptrdiff_t>(rank), lengths.end());
  return lengths[rank];
}

// The decision rule (verify.h, Verdict) on out's e, U and T, with the guards that keep a pass honest, and the
// advice when the set-up cannot decide (or decides with T / U below 2).
void Decide(const VerifyOptions& options, double distance_mm, int features, Verification* out) {
  const double e = out->error_p95_display_px, u = out->expanded_uncertainty_display_px;
  const double t = out->tolerance_display_px;
  const double outlier_share = features > 0 ? static_cast<double>(out->field_outliers) / features : 0;
  std::string guard;
  if (out->noise_px > options.max_noise_px) {
    guard = fmt::format("the residual scatter about the field, {:.3f} camera px per coordinate, is beyond detection "
                        "noise ({:g} px): the residuals hold an error rougher than the field resolves, or the photo is "
                        "too poor",
                        out->noise_px, options.max_noise_px);
  } else if (outlier_share > 0.05) {
    guard = fmt::format("{} of {} features ({:.0f}%) lie far beyond the noise and the smooth field (a local error or "
                        "bad detections): more than the 5% the percentile may leave out",
                        out->field_outliers, features, 100 * outlier_share);
  }
  if (e - u > t) {
    out->verdict = Verdict::kFail;
    out->verdict_reason = fmt::format(
        "fail: the correction error's 95th percentile e = {:.3f} display px exceeds the tolerance {:g} by more than "
        "its expanded uncertainty U = {:.3f}",
        e, t, u);
  } else if (e + u <= t && guard.empty()) {
    out->verdict = Verdict::kPass;
    out->verdict_reason = fmt::format(
        "pass: e + U = {:.3f} + {:.3f} display px is within the tolerance {:g}", e, u, t);
  } else {
    out->verdict = Verdict::kInconclusive;
    out->verdict_reason =
        guard.empty() ? fmt::format("inconclusive: e = {:.3f} display px is within U = {:.3f} of the tolerance {:g}; "
                                    "this set-up cannot decide at this tolerance",
                                    e, u, t)
                      : fmt::format("inconclusive: e + U = {:.3f} + {:.3f} display px is within the tolerance {:g}, "
                                    "but {}",
                                    e, u, t, guard);
  }
  out->pass = out->verdict == Verdict::kPass;

  // Advice. U is noise through the camera's resolving power: it scales with the display px per camera px, that
  // is with the viewing distance and inversely with the focal length in px, and as 1 / sqrt(features).
  const bool weak = out->tolerance_ratio < 2;
  if (out->verdict == Verdict::kInconclusive && !guard.empty()) {
    out->advice = "sharpen the focus, expose without clipping, shoot at base ISO and without digital zoom; if the "
                  "scatter stays, the correction has an error rough at the feature spacing: a denser pattern "
                  "resolves it";
    return;
  }
  if (out->verdict != Verdict::kInconclusive && !weak) return;
  const double target = out->verdict == Verdict::kInconclusive ? 0.8 * std::abs(t - e) : 0.5 * t;
  if (!(target > 0.02 * t)) {
    out->advice = fmt::format("e = {:.3f} display px is too close to the tolerance {:g} for any set-up to decide", e, t);
    return;
  }
  const double factor = u / target;
  if (!(factor > 1)) return;
  out->advice = fmt::format(
      "U = {:.3f} display px (T/U = {:.2f}) must fall to {:.3f}{}: the camera sees {:.2f} display px per camera px "
      "from {:.2f} m. Render for and photograph from a viewpoint about {:.2f} m away, or use {:.1f}x the focal length "
      "in px (a longer lens, or more sensor pixels across the same view), or a pattern with about {:.0f} features "
      "(now {})",
      u, out->tolerance_ratio, target, out->verdict == Verdict::kInconclusive ? " to decide" : " for T/U >= 2",
      out->display_px_per_camera_px, distance_mm / 1000, distance_mm / factor / 1000, factor,
      std::ceil(features * factor * factor), features);
}

}  // namespace

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kPass: return "pass";
    case Verdict::kFail: return "fail";
    case Verdict::kInconclusive: return "inconclusive";
  }
  return "inconclusive";
}

const char* VerdictLabel(Verdict v) {
  switch (v) {
    case Verdict::kPass: return "PASS";
    case Verdict::kFail: return "FAIL";
    case Verdict::kInconclusive: return "INCONCLUSIVE";
  }
  return "INCONCLUSIVE";
}

void VerifyOptions::Check(const std::string& where) const {
  if (!(tolerance_display_px > 0) || !std::isfinite(tolerance_display_px)) {
    throw Error(where, fmt::format("the tolerance is {} display px; it must be a positive number", tolerance_display_px),
                "give e.g. 0.5");
  }
  if (max_field_degree < 0 || max_field_degree > 30) {
    throw Error(where, fmt::format("max_field_degree is {}; give 0 to 30", max_field_degree));
  }
  if (!(detector_systematic_px >= 0) || !std::isfinite(detector_systematic_px)) {
    throw Error(where, fmt::format("detector_systematic_px is {}; give 0 or more camera px", detector_systematic_px));
  }
  if (!(max_noise_px > 0) || !(outlier_sigmas > 0) || uncertainty_draws < 100) {
    throw Error(where, "max_noise_px and outlier_sigmas must be positive, uncertainty_draws at least 100");
  }
  if (min_features < 5) {
    throw Error(where, fmt::format("min_features is {}; the homography needs at least 5 features to leave a residual",
                                   min_features));
  }
}

PatternPlane PatternPlaneFromJson(const nlohmann::json& pattern_json, const std::string& where) {
  if (!pattern_json.contains("pattern") || !pattern_json["pattern"].is_object() ||
      !pattern_json["pattern"].contains("plane") || !pattern_json["pattern"]["plane"].is_object()) {
    throw Error(where, "pattern.json has no pattern.plane object", "write pattern.json with `curvecheck render`");
  }
  const nlohmann::json& j = pattern_json["pattern"]["plane"];
  PatternPlane plane;
  plane.origin_in_screen = JsonVector3(j, "origin_mm", where);
  plane.x_axis_in_screen = JsonVector3(j, "x_axis", where);
  plane.y_axis_in_screen = JsonVector3(j, "y_axis", where);
  plane.Check(where);
  return plane;
}

Verification VerifyCorrection(const PatternFile& pattern, const CameraModel& camera,
                              const std::vector<std::string>& ids, const std::vector<Eigen::Vector2d>& detected_px,
                              const VerifyOptions& options) {
  options.Check("verification options");
  if (ids.size() != detected_px.size()) {
    throw Error("verification", fmt::format("{} ids but {} detections", ids.size(), detected_px.size()));
  }
  const PatternPlane plane = PatternPlaneFromJson(pattern.raw, "pattern.json");
  std::map<std::string, const Feature*> by_id;
  for (const Feature& f : pattern.features) by_id[f.id] = &f;

  Verification out;
  out.tolerance_display_px = options.tolerance_display_px;
  for (size_t i = 0; i < ids.size(); ++i) {
    const auto it = by_id.find(ids[i]);
    if (it == by_id.end()) {
      throw Error("pattern.json", fmt::format("detected feature '{}' is not in the pattern", ids[i]),
                  "analyse the photo with the pattern.json it shows");
    }
    if (!it->second->display_px) continue;
    FeatureCheck c;
    c.id = ids[i];
    c.pattern_mm = it->second->pattern_mm;
    c.display_px = *it->second->display_px;
    c.detected_px = detected_px[i];
    out.features.push_back(c);
  }
  const int n = static_cast<int>(out.features.size());
  if (n < options.min_features) {
    out.failure_kind = VerificationFailure::kTooFewFeatures;
    out.failure = fmt::format("only {} usable features; at least {} are needed for a verdict", n, options.min_features);
    return out;
  }

  // Centre and scale the pattern coordinates (conditioning of the DLT and of the 8 parameters).
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const FeatureCheck& c : out.features) centre += c.pattern_mm;
  centre /= n;
  double scale = 0;
  for (const FeatureCheck& c : out.features) scale += (c.pattern_mm - centre).norm();
  scale = std::max(scale / n, 1e-9);
  std::vector<Eigen::Vector2d> m(n), normalized(n);
  std::vector<Eigen::Vector2d> detected(n);
  for (int i = 0; i < n; ++i) {
    m[i] = (out.features[i].pattern_mm - centre) / scale;
    detected[i] = out.features[i].detected_px;
  }
  const std::vector<Eigen::Vector3d> rays = UnprojectPixels(camera, detected);
  for (int i = 0; i < n; ++i) {
    if (!(rays[i].z() > 0)) {
      out.failure_kind = VerificationFailure::kLensMismatch;
      out.failure = fmt::format("feature {} unprojects behind the camera; the lens model does not fit this photo",
                                out.features[i].id);
      return out;
    }
    normalized[i] = rays[i].head<2>() / rays[i].z();
  }
  Eigen::Matrix3d h = Dlt(m, normalized);
  if (h(2, 2) < 0) h = -h;
  if (!(std::abs(h(2, 2)) > 1e-12)) {
    out.failure_kind = VerificationFailure::kDegenerate;
    out.failure = "the pattern's centre is not in front of the camera; no planar perspective image to fit";
    return out;
  }
  h /= h(2, 2);

  double h8[8];
  for (int k = 0; k < 8; ++k) h8[k] = h(k / 3, k % 3);
  ceres::Problem problem;
  for (int i = 0; i < n; ++i) {
    problem.AddResidualBlock(new HomographyResidual(camera, m[i], detected[i]), nullptr, h8);
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 50;
  solver.function_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-14;
  solver.gradient_tolerance = 1e-16;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    out.failure_kind = VerificationFailure::kDegenerate;
    out.failure = "the homography fit did not converge: " + summary.message;
    return out;
  }
  const Eigen::Matrix3d h_centred = HomographyResidual::FromParameters(h8);
  // Back to raw pattern mm: m = T (a, b, 1) with T the centring and scaling.
  Eigen::Matrix3d t;
  t << 1 / scale, 0, -centre.x() / scale, 0, 1 / scale, -centre.y() / scale, 0, 0, 1;
  out.homography = h_centred * t;

  double sum_px = 0, sum_display = 0, sum_arcmin = 0;
  ErrorFieldInput field_in;
  std::vector<int> field_feature;  // feature index of each field input
  std::vector<Eigen::Matrix<double, 2, 8>> nuisance_rows;
  for (int i = 0; i < n; ++i) {
    FeatureCheck& c = out.features[i];
    const Eigen::Vector3d p = h_centred * Eigen::Vector3d(m[i].x(), m[i].y(), 1);
    std::vector<Eigen::Matrix<double, 2, 3>> dq_dp;
    c.expected_px = ProjectPoints(camera, {p}, &dq_dp)[0];
    c.residual_px = c.detected_px - c.expected_px;
    c.residual_arcmin = AngleRad(rays[i], p) * kArcminPerRad;

    // d q / d(a, b): the homography's columns for a and b, through the lens.
    const Eigen::Matrix<double, 2, 2> dq_dab = dq_dp[0] * out.homography.leftCols<2>();
    // d(a, b) / d(display px): the rendering's correction mapping, central differences of half a pixel.
    Eigen::Matrix2d dab_dd;
    bool ok = true;
    for (int axis = 0; axis < 2; ++axis) {
      const Eigen::Vector2d step = 0.5 * Eigen::Vector2d::Unit(axis);
      const auto plus = PatternFromDisplayPx(pattern.monitor, pattern.viewpoint_in_screen, plane, c.display_px + step);
      const auto minus = PatternFromDisplayPx(pattern.monitor, pattern.viewpoint_in_screen, plane, c.display_px - step);
      if (!plus || !minus) {
        ok = false;
        break;
      }
      dab_dd.col(axis) = (*plus - *minus) / 1.0;
    }
    const Eigen::Matrix2d j = dq_dab * dab_dd;
    if (ok && std::abs(j.determinant()) > 1e-12) {
      c.residual_display_px = j.inverse() * c.residual_px;
      field_in.display_px.push_back(c.display_px);
      field_in.jacobian.push_back(j);
      field_in.residual_px.push_back(c.residual_px);
      if (options.pixel_locking) field_in.camera_px.push_back(c.detected_px);
      field_feature.push_back(i);
      // The homography's directions at this feature: d q / d h8 (the residual's Jacobian, up to its sign).
      Eigen::Matrix<double, 2, 8> rows;
      for (int index = 0; index < 8; ++index) rows.col(index) = dq_dp[0].col(index / 3) * (index % 3 == 2 ? 1.0 : m[i](index % 3));
      nuisance_rows.push_back(rows);
    } else {
      c.residual_display_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
    sum_px += c.residual_px.squaredNorm();
    sum_display += c.residual_display_px.squaredNorm();
    sum_arcmin += c.residual_arcmin * c.residual_arcmin;
    out.max_px = std::max(out.max_px, c.residual_px.norm());
    out.max_display_px = std::max(out.max_display_px, c.residual_display_px.norm());
    out.max_arcmin = std::max(out.max_arcmin, c.residual_arcmin);
  }
  out.rms_px = std::sqrt(sum_px / n);
  out.rms_display_px = std::sqrt(sum_display / n);
  out.rms_arcmin = std::sqrt(sum_arcmin / n);
  out.p95_display_px = Percentile95Length(out.features);

  const int nf = static_cast<int>(field_in.display_px.size());
  if (nf < options.min_features) {
    out.failure_kind = VerificationFailure::kDegenerate;
    out.failure = fmt::format("only {} of {} features have a display-px residual (the correction mapping is undefined "
                              "at the others); at least {} are needed for a verdict",
                              nf, n, options.min_features);
    return out;
  }
  field_in.nuisance.resize(2 * nf, 8);
  for (int k = 0; k < nf; ++k) field_in.nuisance.middleRows(2 * k, 2) = nuisance_rows[static_cast<size_t>(k)];
  ErrorFieldOptions field_options;
  field_options.max_degree = options.max_field_degree;
  field_options.outlier_sigmas = options.outlier_sigmas;
  field_options.outlier_floor_px = options.detector_systematic_px;
  field_options.draws = options.uncertainty_draws;
  const ErrorField field = EstimateErrorField(field_in, field_options);
  std::vector<double> display_per_camera;
  for (int k = 0; k < nf; ++k) {
    FeatureCheck& c = out.features[static_cast<size_t>(field_feature[static_cast<size_t>(k)])];
    const Eigen::Matrix2d j_inv = field_in.jacobian[static_cast<size_t>(k)].inverse();
    c.residual_display_sigma_px = field.noise_px * (j_inv * j_inv.transpose()).diagonal().cwiseSqrt();
    c.error_display_px = field.value[static_cast<size_t>(k)];
    c.error_display_sigma_px = field.covariance[static_cast<size_t>(k)].diagonal().cwiseMax(0).cwiseSqrt();
    c.field_outlier = field.outlier[static_cast<size_t>(k)];
    c.pixel_locking_px = field.pixel_locking.BiasAt(c.detected_px);
    display_per_camera.push_back(std::sqrt(std::abs(j_inv.determinant())));
  }
  out.noise_px = field.noise_px;
  out.pixel_locking = field.pixel_locking;
  out.field_degree = std::max(field.degree_u, field.degree_v);
  out.field_outliers = static_cast<int>(std::count(field.outlier.begin(), field.outlier.end(), true));
  out.display_px_per_camera_px = Median(display_per_camera);
  std::vector<double> lengths;
  for (const Eigen::Vector2d& f : field.value) lengths.push_back(f.norm());
  out.error_p95_display_px = Percentile(lengths, 95);
  out.field_band_display_px = field.band95_display_px;
  out.systematic_display_px = 2 * options.detector_systematic_px * out.display_px_per_camera_px;
  out.expanded_uncertainty_display_px = std::hypot(out.field_band_display_px, out.systematic_display_px);
  out.coverage_factor = field.rms_sigma_display_px > 0 ? field.band95_display_px / field.rms_sigma_display_px : 0;
  out.tolerance_ratio = out.tolerance_display_px / std::max(out.expanded_uncertainty_display_px, 1e-12);
  const double distance_mm = (pattern.viewpoint_in_screen - ScreenCentreInScreen(pattern.monitor)).norm();
  Decide(options, distance_mm, nf, &out);
  return out;
}

Verification CombineVerifications(const std::vector<Verification>& photos, const VerifyOptions& options) {
  Verification out;
  out.tolerance_display_px = options.tolerance_display_px;
  double sum_px = 0, sum_display = 0, sum_arcmin = 0;
  int n = 0, verdicts = 0, fails = 0, passes = 0;
  const Verification* decides = nullptr;
  for (const Verification& v : photos) {
    if (!v.failure.empty()) continue;
    ++verdicts;
    fails += v.verdict == Verdict::kFail ? 1 : 0;
    passes += v.verdict == Verdict::kPass ? 1 : 0;
    for (const FeatureCheck& c : v.features) {
      sum_px += c.residual_px.squaredNorm();
      sum_display += c.residual_display_px.squaredNorm();
      sum_arcmin += c.residual_arcmin * c.residual_arcmin;
      ++n;
    }
    out.max_px = std::max(out.max_px, v.max_px);
    out.max_display_px = std::max(out.max_display_px, v.max_display_px);
    out.max_arcmin = std::max(out.max_arcmin, v.max_arcmin);
  }
  if (verdicts == 0) {
    out.failure_kind = VerificationFailure::kNoVerdict;
    out.failure = "no photo gave a verdict";
    return out;
  }
  // The deciding photo: among failures the clearest (largest e - U); otherwise the one nearest to failing
  // (largest e + U).
  for (const Verification& v : photos) {
    if (!v.failure.empty()) continue;
    const double key = fails > 0 ? v.error_p95_display_px - v.expanded_uncertainty_display_px
                                 : v.error_p95_display_px + v.expanded_uncertainty_display_px;
    if (fails > 0 && v.verdict != Verdict::kFail) continue;
    if (!decides || key > (fails > 0 ? decides->error_p95_display_px - decides->expanded_uncertainty_display_px
                                     : decides->error_p95_display_px + decides->expanded_uncertainty_display_px)) {
      decides = &v;
    }
  }
  out.rms_px = std::sqrt(sum_px / n);
  out.rms_display_px = std::sqrt(sum_display / n);
  out.rms_arcmin = std::sqrt(sum_arcmin / n);
  std::vector<FeatureCheck> all;
  for (const Verification& v : photos) {
    if (v.failure.empty()) all.insert(all.end(), v.features.begin(), v.features.end());
  }
  out.p95_display_px = Percentile95Length(all);
  out.features = std::move(all);
  out.verdict = fails > 0 ? Verdict::kFail : passes == verdicts ? Verdict::kPass : Verdict::kInconclusive;
  out.pass = out.verdict == Verdict::kPass;
  out.error_p95_display_px = decides->error_p95_display_px;
  out.expanded_uncertainty_display_px = decides->expanded_uncertainty_display_px;
  out.coverage_factor = decides->coverage_factor;
  out.field_band_display_px = decides->field_band_display_px;
  out.systematic_display_px = decides->systematic_display_px;
  out.tolerance_ratio = decides->tolerance_ratio;
  out.noise_px = decides->noise_px;
  out.display_px_per_camera_px = decides->display_px_per_camera_px;
  out.field_degree = decides->field_degree;
  out.field_outliers = decides->field_outliers;
  out.advice = decides->advice;
  out.verdict_reason = verdicts == 1 ? decides->verdict_reason
                                     : fmt::format("{} ({} of {} photos pass, {} fail; this one decides)",
                                                   decides->verdict_reason, passes, verdicts, fails);
  return out;
}

}  // namespace curvecheck
