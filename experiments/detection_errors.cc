#include "experiments/detection_errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "analysis/screen_fit.h"

namespace curvecheck::experiments {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
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

}  // namespace

DetectionErrors DetectionErrorsOf(const std::vector<Eigen::Vector2d>& at, const std::vector<Eigen::Vector2d>& err,
                                  const std::vector<int>& photo, int width, int height) {
  DetectionErrors e;
  e.points = static_cast<int>(err.size());
  e.rms_px = e.smooth_rms_px = e.smooth_beyond_noise_px = e.per_photo_smooth_rms_px = kNaN;
  e.mean_px.setConstant(kNaN);
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
