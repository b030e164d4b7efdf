#include "experiments/detection_errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "analysis/screen_fit.h"

namespace curvecheck::experiments {
namespace {

constexpr size_t kMinPoints = 20;

Eigen::MatrixXd Stack(const std::vector<Eigen::Vector2d>& v) {
  Eigen::MatrixXd y(static_cast<long>(v.size()), 2);
  for (size_t i = 0; i < v.size(); ++i) y.row(static_cast<long>(i)) = v[i].transpose();
  return y;
}

// The squared norm of the least-squares fit of `y` (n x 2) on `basis`.
double FittedSquaredNorm(const Eigen::MatrixXd& basis, const Eigen::MatrixXd& y) {
  return (basis * basis.colPivHouseholderQr().solve(y)).squaredNorm();
}

// RMS per coordinate of what the periodic signature leaves of `err` (DetectionErrors::signature_remainder_px):
// `cell` adds the 2 x 2 cell's terms.
double SignatureRemainder(const std::vector<Eigen::Vector2d>& at, const std::vector<Eigen::Vector2d>& err, bool cell) {
  const long n = static_cast<long>(err.size()), columns = cell ? 11 : 5;
  double rest = 0;
  for (int c = 0; c < 2; ++c) {
    Eigen::MatrixXd x(n, columns);
    Eigen::VectorXd y(n);
    for (long i = 0; i < n; ++i) {
      const Eigen::Vector2d t = at[static_cast<size_t>(i)] - err[static_cast<size_t>(i)];
      const double own = t[c], other = t[1 - c];
      x(i, 0) = 1;
      x(i, 1) = std::sin(2 * M_PI * own), x(i, 2) = std::cos(2 * M_PI * own);
      x(i, 3) = std::sin(M_PI * own), x(i, 4) = std::cos(M_PI * own);
      if (cell) {
        x(i, 5) = std::sin(M_PI * other), x(i, 6) = std::cos(M_PI * other);
        const double sx = std::sin(M_PI * t.x()), cx = std::cos(M_PI * t.x()), sy = std::sin(M_PI * t.y()),
                     cy = std::cos(M_PI * t.y());
        x(i, 7) = sx * sy, x(i, 8) = sx * cy, x(i, 9) = cx * sy, x(i, 10) = cx * cy;
      }
      y[i] = err[static_cast<size_t>(i)][c];
    }
    rest += (y - x * x.colPivHouseholderQr().solve(y)).squaredNorm();
  }
  return std::sqrt(rest / (2.0 * static_cast<double>(n - columns)));
}

}  // namespace

DetectionErrors DetectionErrorsOf(const std::vector<Eigen::Vector2d>& at, const std::vector<Eigen::Vector2d>& err,
                                  const std::vector<int>& photo, int width, int height) {
  DetectionErrors e;
  e.points = static_cast<int>(err.size());
  if (err.size() < kMinPoints || at.size() != err.size() || photo.size() != err.size()) return e;
  const double n = static_cast<double>(err.size());
  const Eigen::MatrixXd y = Stack(err);
  e.rms_px = std::sqrt(y.squaredNorm() / (2 * n));
  e.mean_px = y.colwise().mean().transpose();
  const Eigen::MatrixXd basis = LegendreFieldBasis(at, width, height, 3);
  const double fitted = FittedSquaredNorm(basis, y), k = static_cast<double>(basis.cols());
  e.smooth_rms_px = std::sqrt(fitted / (2 * n));
  const double rest_variance = (y.squaredNorm() - fitted) / (2 * (n - k));
  e.smooth_beyond_noise_px = std::sqrt(std::max(0.0, fitted / (2 * n) - rest_variance * k / n));
  e.signature_remainder_px = SignatureRemainder(at, err, false);
  e.cell_signature_remainder_px = SignatureRemainder(at, err, true);
  double sum = 0;
  size_t count = 0;
  for (int p = 0; p <= *std::max_element(photo.begin(), photo.end()); ++p) {
    std::vector<Eigen::Vector2d> a, r;
    for (size_t i = 0; i < err.size(); ++i) {
      if (photo[i] == p) a.push_back(at[i]), r.push_back(err[i]);
    }
    if (a.size() < kMinPoints) continue;
    sum += FittedSquaredNorm(LegendreFieldBasis(a, width, height, 2), Stack(r));
    count += a.size();
  }
  if (count > 0) e.per_photo_smooth_rms_px = std::sqrt(sum / (2.0 * static_cast<double>(count)));
  return e;
}

}  // namespace curvecheck::experiments
