// The data-only parts of the screen fit's uncertainty budget (analysis/screen_fit.h): the pixel-locking
// regression, the coverage factor, the Legendre bias fields and the lens covariance sidecar. The propagation
// through the fit's linearization lives in screen_fit.cc, beside the problem it linearizes.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <nlohmann/json.hpp>

#include "analysis/screen_fit.h"
#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The standard normal quantile: Newton on 0.5 erfc(-z/sqrt 2) = p from z = 0 (monotone, converges in < 10 steps
// for 1e-12 < p < 1 - 1e-12).
double NormalQuantile(double p) {
  double z = 0;
  for (int i = 0; i < 100; ++i) {
    const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
    const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2 * kPi);
    const double step = (cdf - p) / std::max(pdf, 1e-300);
    z -= step;
    if (std::abs(step) < 1e-14) break;
  }
  return z;
}

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

ResidualPixelLocking EstimatePixelLocking(const std::vector<Eigen::Vector2d>& detected_px,
                                  const std::vector<Eigen::Vector2d>& residual_px) {
  if (detected_px.size() != residual_px.size()) {
    throw Error("pixel-locking estimate", "detections and residuals differ in number", "");
  }
  ResidualPixelLocking out;
  for (int c = 0; c < 2; ++c) {
    std::vector<Eigen::Vector3d> rows;
    std::vector<double> y;
    for (size_t i = 0; i < detected_px.size(); ++i) {
      if (!detected_px[i].allFinite() || !residual_px[i].allFinite()) continue;
      const double phase = 2 * kPi * (detected_px[i][c] - std::floor(detected_px[i][c]));
      rows.emplace_back(1.0, std::sin(phase), std::cos(phase));
      y.push_back(residual_px[i][c]);
    }
    const int n = static_cast<int>(y.size());
    out.observations = n;
    if (n < 6) {
      out.amplitude_px[c] = out.sigma_px[c] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    Eigen::MatrixXd x(n, 3);
    Eigen::VectorXd yv(n);
    for (int i = 0; i < n; ++i) x.row(i) = rows[static_cast<size_t>(i)].transpose(), yv[i] = y[static_cast<size_t>(i)];
    const Eigen::Matrix3d xtx = x.transpose() * x;
    const Eigen::Vector3d beta = xtx.ldlt().solve(x.transpose() * yv);
    const double s2 = (yv - x * beta).squaredNorm() / (n - 3);
    const Eigen::Matrix2d cov = (s2 * xtx.inverse()).bottomRightCorner<2, 2>();
    const Eigen::Vector2d ab = beta.tail<2>();
    const double a = ab.norm();
    out.amplitude_px[c] = a;
    // Delta method along the estimate's direction; near zero (a below its own noise) the direction is
    // undefined and the coefficients' RMS sigma is the amplitude's scale.
    const double rms_sigma = std::sqrt(0.5 * cov.trace());
    out.sigma_px[c] = a > 3 * rms_sigma ? std::sqrt((ab / a).dot(cov * (ab / a))) : rms_sigma;
  }
  return out;
}

double StudentTCoverageFactor(double p, double dof) {
  if (!(p > 0 && p < 1)) throw Error("coverage factor", fmt::format("coverage probability {} is not in (0, 1)", p), "");
  if (!(dof >= 1)) throw Error("coverage factor", fmt::format("{} degrees of freedom", dof), "need at least 1");
  const double x = NormalQuantile(0.5 + 0.5 * p);
  if (std::isinf(dof)) return x;
  const double x2 = x * x, x3 = x2 * x, x5 = x3 * x2, x7 = x5 * x2, x9 = x7 * x2;
  const double g1 = (x3 + x) / 4;
  const double g2 = (5 * x5 + 16 * x3 + 3 * x) / 96;
  const double g3 = (3 * x7 + 19 * x5 + 17 * x3 - 15 * x) / 384;
  const double g4 = (79 * x9 + 776 * x7 + 1482 * x5 - 1920 * x3 - 945 * x) / 92160;
  const double v = dof;
  return x + g1 / v + g2 / (v * v) + g3 / (v * v * v) + g4 / (v * v * v * v);
}

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

Eigen::MatrixXd GaussianFieldBasis(const std::vector<Eigen::Vector2d>& points_px, double length_px, int features,
                                   unsigned seed) {
  if (!(length_px > 0) || features < 1) {
    throw Error("Gaussian field basis", fmt::format("length {} px, {} features", length_px, features), "");
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> phase(0, 6.283185307179586);
  Eigen::MatrixXd omega(features, 2);
  Eigen::VectorXd offset(features);
  for (int m = 0; m < features; ++m) omega(m, 0) = unit(rng), omega(m, 1) = unit(rng), offset[m] = phase(rng);
  const double scale = std::sqrt(2.0 / features);
  Eigen::MatrixXd b(static_cast<long>(points_px.size()), features);
  for (size_t r = 0; r < points_px.size(); ++r) {
    for (int m = 0; m < features; ++m) {
      const double arg = (omega(m, 0) * points_px[r].x() + omega(m, 1) * points_px[r].y()) / length_px + offset[m];
      b(static_cast<long>(r), m) = scale * std::cos(arg);
    }
  }
  return b;
}

std::filesystem::path IntrinsicsCovariancePathFor(const std::filesystem::path& camera_path) {
  std::filesystem::path p = camera_path;
  p.replace_extension(".intrinsics_covariance.json");
  return p;
}

IntrinsicsCovariance ReadIntrinsicsCovariance(const std::filesystem::path& path, const CameraModel& camera) {
  const std::string where = path.string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ReadFileToString(path));
  } catch (const nlohmann::json::exception& e) {
    throw Error(where, std::string("not valid JSON: ") + e.what(),
                "write it with curvecheck calibrate (format curvecheck.intrinsics_covariance/1)");
  }
  const auto fix = "give the covariance written with this camera model by curvecheck calibrate";
  if (j.value("format", "") != "curvecheck.intrinsics_covariance/1") {
    throw Error(where, fmt::format("format is '{}', not curvecheck.intrinsics_covariance/1", j.value("format", "")),
                fix);
  }
  if (j.value("lensmodel", "") != camera.lensmodel) {
    throw Error(where,
                fmt::format("lens model {} does not match the camera model's {}", j.value("lensmodel", ""),
                            camera.lensmodel),
                fix);
  }
  const size_t n = camera.intrinsics.size();
  if (!j.contains("covariance") || !j["covariance"].is_array() || j["covariance"].size() != n) {
    throw Error(where, fmt::format("covariance must be {} rows of {} numbers", n, n), fix);
  }
  IntrinsicsCovariance out;
  out.source = where;
  out.covariance.resize(static_cast<long>(n), static_cast<long>(n));
  for (size_t r = 0; r < n; ++r) {
    const nlohmann::json& row = j["covariance"][r];
    if (!row.is_array() || row.size() != n) throw Error(where, fmt::format("covariance row {} is not {} numbers", r, n), fix);
    for (size_t c = 0; c < n; ++c) {
      if (!row[c].is_number()) throw Error(where, fmt::format("covariance[{}][{}] is not a number", r, c), fix);
      out.covariance(static_cast<long>(r), static_cast<long>(c)) = row[c].get<double>();
    }
  }
  if (!out.covariance.allFinite() || (out.covariance - out.covariance.transpose()).norm() >
                                         1e-9 * std::max(1e-300, out.covariance.norm())) {
    throw Error(where, "the covariance is not finite and symmetric", fix);
  }
  for (size_t i = 0; i < n; ++i) {
    if (out.covariance(static_cast<long>(i), static_cast<long>(i)) < 0) {
      throw Error(where, fmt::format("variance {} is negative", i), fix);
    }
  }
  if (j.contains("dof") && j["dof"].is_number() && j["dof"].get<double>() >= 1) out.dof = j["dof"].get<double>();
  return out;
}

}  // namespace curvecheck
