#include "analysis/screen_model.h"

#include <fmt/format.h>

#include <Eigen/QR>
#include <cmath>

#include "core/error.h"
#include "core/math_util.h"

namespace curvecheck {

const char* ScreenModelName(ScreenModelKind kind) {
  switch (kind) {
    case ScreenModelKind::kFlat: return "flat";
    case ScreenModelKind::kCylinder: return "cylinder";
    case ScreenModelKind::kCylinderLean: return "cylinder+lean";
    case ScreenModelKind::kVaryingCurvature: return "varying-curvature";
    case ScreenModelKind::kVaryingCurvatureQuadratic: return "varying-curvature-quadratic";
    case ScreenModelKind::kCylinderDeviation: return "cylinder+deviation";
  }
  return "?";
}

std::vector<ScreenModelKind> AllScreenModels() {
  return {ScreenModelKind::kFlat,           ScreenModelKind::kCylinder,
          ScreenModelKind::kCylinderLean,   ScreenModelKind::kVaryingCurvature,
          ScreenModelKind::kVaryingCurvatureQuadratic, ScreenModelKind::kCylinderDeviation};
}

ScreenModelKind ParseScreenModel(const std::string& name, const std::string& where) {
  std::string known;
  for (ScreenModelKind k : AllScreenModels()) {
    if (name == ScreenModelName(k)) return k;
    known += (known.empty() ? "" : ", ") + std::string(ScreenModelName(k));
  }
  throw Error(where, fmt::format("'{}' is not a screen model", name), "use one of: " + known);
}

std::vector<ScreenModelKind> ParseScreenModels(const std::vector<std::string>& names, const std::string& where) {
  std::vector<ScreenModelKind> kinds;
  for (const std::string& name : names) kinds.push_back(ParseScreenModel(name, where));
  return kinds;
}

int CoreParameterCount(ScreenModelKind kind) {
  switch (kind) {
    case ScreenModelKind::kFlat: return 0;
    case ScreenModelKind::kCylinder: return 1;
    case ScreenModelKind::kCylinderLean: return 2;
    case ScreenModelKind::kVaryingCurvature: return 2;
    case ScreenModelKind::kVaryingCurvatureQuadratic: return 3;
    case ScreenModelKind::kCylinderDeviation: return 1;
  }
  return 0;
}

double CubicBSpline(double t) {
  const double a = std::abs(t);
  if (a < 1) return 2.0 / 3.0 - a * a + 0.5 * a * a * a;
  if (a < 2) return (2 - a) * (2 - a) * (2 - a) / 6.0;
  return 0;
}

DeviationBasis::DeviationBasis(const Monitor& monitor, double curvature_per_mm, int nu, int nv)
    : nu_(nu), nv_(nv), k_(curvature_per_mm), half_width_mm_(0.5 * monitor.width_mm) {
  monitor.Check("deviation basis");
  if (nu < 4 || nv < 4) {
    throw Error("deviation basis", fmt::format("{} x {} B-spline coefficients are too few", nu, nv),
                "give at least 4 x 4 (5 modes are removed)");
  }
  theta_ = k_ * half_width_mm_;
  // Gram matrix of the modes against the splines over a dense grid of the screen (L2 inner product), then the
  // orthonormal complement of its row space: the last n - 5 columns of Q in G^T = Q R.
  const int n = nu * nv;
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, 5);
  constexpr int kGridU = 161, kGridV = 81;
  for (int j = 0; j < kGridV; ++j) {
    for (int i = 0; i < kGridU; ++i) {
      const Eigen::Vector2d uv(-1 + 2.0 * i / (kGridU - 1), -1 + 2.0 * j / (kGridV - 1));
      g += Splines(uv) * Modes(uv).transpose();
    }
  }
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(g);
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(n, n);
  null_ = q.rightCols(n - 5);
}

Eigen::VectorXd DeviationBasis::Splines(const Eigen::Vector2d& uv) const {
  // Coefficient i sits at u_i = -1 + (i - 1) hu, i = 0..nu-1 (one knot spacing beyond each edge).
  const double hu = 2.0 / (nu_ - 3), hv = 2.0 / (nv_ - 3);
  Eigen::VectorXd bu(nu_), bv(nv_);
  for (int i = 0; i < nu_; ++i) bu[i] = CubicBSpline((uv.x() - (-1 + (i - 1) * hu)) / hu);
  for (int j = 0; j < nv_; ++j) bv[j] = CubicBSpline((uv.y() - (-1 + (j - 1) * hv)) / hv);
  Eigen::VectorXd b(nu_ * nv_);
  for (int j = 0; j < nv_; ++j) b.segment(j * nu_, nu_) = bv[j] * bu;
  return b;
}

Eigen::Matrix<double, 5, 1> DeviationBasis::Modes(const Eigen::Vector2d& uv) const {
  // In units of the half width: s/h = u, phi = theta u; (1 - cos phi)/(k h)^2 = u^2 sinc^2(phi/2)/2.
  const double phi = theta_ * uv.x();
  const double c = std::cos(phi), s = uv.x() * Sinc(phi);  // sin(phi)/theta, stays ~u as theta -> 0
  const double half = Sinc(0.5 * phi);
  Eigen::Matrix<double, 5, 1> m;
  m << c, s, uv.y() * c, uv.y() * s, 0.5 * uv.x() * uv.x() * half * half;
  return m;
}

Eigen::VectorXd DeviationBasis::Weights(const Eigen::Vector2d& uv) const {
  return null_.transpose() * Splines(uv);
}

}  // namespace curvecheck
