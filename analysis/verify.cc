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

#include "core/error.h"

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

}  // namespace

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kPass: return "pass";
    case Verdict::kFail: return "fail";
    case Verdict::kInconclusive: return "inconclusive";
  }
  return "inconclusive";
}

void VerifyOptions::Check(const std::string& where) const {
  if (!(tolerance_display_px > 0) || !std::isfinite(tolerance_display_px)) {
    throw Error(where, fmt::format("the tolerance is {} display px; it must be a positive number", tolerance_display_px),
                "give e.g. 0.5");
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
  out.pass = out.p95_display_px <= options.tolerance_display_px;
  out.verdict = out.pass ? Verdict::kPass : Verdict::kFail;
  return out;
}

Verification CombineVerifications(const std::vector<Verification>& photos, const VerifyOptions& options) {
  Verification out;
  out.tolerance_display_px = options.tolerance_display_px;
  double sum_px = 0, sum_display = 0, sum_arcmin = 0;
  int n = 0, verdicts = 0;
  bool all_pass = true;
  for (const Verification& v : photos) {
    if (!v.failure.empty()) continue;
    ++verdicts;
    all_pass = all_pass && v.pass;
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
  out.rms_px = std::sqrt(sum_px / n);
  out.rms_display_px = std::sqrt(sum_display / n);
  out.rms_arcmin = std::sqrt(sum_arcmin / n);
  std::vector<FeatureCheck> all;
  for (const Verification& v : photos) {
    if (v.failure.empty()) all.insert(all.end(), v.features.begin(), v.features.end());
  }
  out.p95_display_px = Percentile95Length(all);
  out.pass = all_pass;
  out.verdict = out.pass ? Verdict::kPass : Verdict::kFail;
  return out;
}

}  // namespace curvecheck
