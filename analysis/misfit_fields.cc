// The lens-model-misfit's field families (analysis/screen_fit.h): the random-feature bases and covariances of the
// Gaussian and ring fields the budget fits to the residuals, the degrees of freedom of a field's mean square over
// the imager, and a stated field scaled to its RMS there, drawn in the imager's Karhunen-Loeve modes
// (NormalisedField). The budget that propagates them is screen_fit_budget.cc and screen_fit_misfit.cc.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "analysis/screen_fit.h"
#include "core/error.h"

namespace curvecheck {
// The arguments are formed and reduced to [-pi, pi] in double, the cosine taken by Eigen's vectorized
// single-precision cosine (absolute error ~1e-7, immaterial for a random basis): libm's double cosine was a sixth
// of a 10-photo fit's time (perf). The reduction rounds by adding and subtracting 1.5 x 2^52 (exact for |t| < 2^51;
// the arguments here are below 1e5), which vectorizes where std::round is a libm call per element; the rows are
// written contiguously (FieldBasis is row-major).
void FieldFeatures::Evaluate(const std::vector<Eigen::Vector2d>& points_px, FieldBasis* out) const {
  constexpr double kTwoPi = 6.283185307179586, kRound = 6755399441055744.0;
  const long features = omega.rows();
  const double scale = std::sqrt(2.0 / static_cast<double>(features));
  out->resize(static_cast<long>(points_px.size()), features);
  const Eigen::ArrayXd wx = omega.col(0).array(), wy = omega.col(1).array(), off = offset.array();
  Eigen::ArrayXd arg(features), turns(features);
  Eigen::ArrayXf reduced(features);
  for (size_t r = 0; r < points_px.size(); ++r) {
    arg = wx * points_px[r].x() + wy * points_px[r].y() + off;
    turns = (arg * (1 / kTwoPi) + kRound) - kRound;
    arg -= kTwoPi * turns;
    // The cosine alone in an expression of its own: inside the casts, Eigen evaluated it one scalar at a time
    // through libm's cosf (a sixth of a ten-photo fit, perf); on a float array it takes its vectorized cosine.
    reduced = arg.cast<float>();
    reduced = reduced.cos();
    out->row(static_cast<long>(r)) = (scale * reduced.cast<double>()).matrix().transpose();
  }
}

FieldBasis FieldFeatures::At(const std::vector<Eigen::Vector2d>& points_px) const {
  FieldBasis b;
  Evaluate(points_px, &b);
  return b;
}

FieldFeatures GaussianFieldFeatures(double length_px, int features, unsigned seed) {
  if (!(length_px > 0) || features < 1) {
    throw Error("Gaussian field features", fmt::format("length {} px, {} features", length_px, features), "");
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> phase(0, 6.283185307179586);
  FieldFeatures f{Eigen::MatrixXd(features, 2), Eigen::VectorXd(features)};
  for (int m = 0; m < features; ++m) f.omega(m, 0) = unit(rng), f.omega(m, 1) = unit(rng), f.offset[m] = phase(rng);
  f.omega /= length_px;
  return f;
}

FieldFeatures RingFieldFeatures(double period_px, int features, unsigned seed) {
  if (!(period_px > 0) || features < 1) {
    throw Error("ring field features", fmt::format("period {} px, {} features", period_px, features), "");
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const double k = 6.283185307179586 / period_px;
  FieldFeatures f{Eigen::MatrixXd(features, 2), Eigen::VectorXd(features)};
  for (int m = 0; m < features; ++m) {
    const double t = 3.141592653589793 * (m + unit(rng)) / features;
    f.omega(m, 0) = k * std::cos(t), f.omega(m, 1) = k * std::sin(t), f.offset[m] = 6.283185307179586 * unit(rng);
  }
  return f;
}

FieldFeatures MisfitComponentFeatures(const UncertaintyBudget::FieldComponent& component, const FitOptions& options) {
  return component.family == UncertaintyBudget::FieldFamily::kRing
             ? RingFieldFeatures(component.length_px, options.misfit_features, options.systematic_field_seed + 3)
             : GaussianFieldFeatures(component.length_px, options.misfit_features, options.systematic_field_seed + 2);
}

double MisfitComponentCovariance(const UncertaintyBudget::FieldComponent& component, double distance_px) {
  if (component.family == UncertaintyBudget::FieldFamily::kRing) {
    return component.variance_px2 * std::cyl_bessel_j(0.0, 6.283185307179586 * distance_px / component.length_px);
  }
  const double z = distance_px / component.length_px;
  return component.variance_px2 * std::exp(-0.5 * z * z);
}

double FieldMeanSquareDof(double length_px, int width, int height) {
  if (!(length_px > 0) || width <= 0 || height <= 0) return std::numeric_limits<double>::infinity();
  // rho^2 = exp(-|d|^2 / L^2) = exp(-dx^2 / L^2) exp(-dy^2 / L^2): the double integral is the product of one
  // per axis, each the mean over a 256-point grid's pairs (spacing <= L / 4 down to L = width / 64).
  const auto mean_rho2 = [&](double extent) {
    constexpr int kGrid = 256;
    double sum = 0;
    for (int i = 0; i < kGrid; ++i) {
      for (int j = 0; j < kGrid; ++j) {
        const double d = (i - j) * extent / kGrid / length_px;
        sum += std::exp(-d * d);
      }
    }
    return sum / (kGrid * kGrid);
  };
  return 1 / (mean_rho2(width) * mean_rho2(height));
}

NormalisedField NormalisedField::Draw(double length_px, int width, int height, int count, unsigned seed) {
  NormalisedField out;
  if (!(length_px > 0) || width <= 0 || height <= 0 || count < 1) return out;
  out.length_px = length_px;
  // One axis's modes: the kernel's eigenvectors v (|v| = 1, K v = mu v) on a grid of g cell centres, with
  // lambda = mu / g (sum 1 over all of them); psi = sqrt(g) v has mean square 1 over the grid (Respond).
  std::array<double, 2> top = {0, 0};
  for (int c = 0; c < 2; ++c) {
    const int extent = c == 0 ? width : height;
    const double per_length = 8.0 * extent / length_px;
    if (per_length > 512) return out;
    const int g = std::clamp(static_cast<int>(std::ceil(per_length)), 64, 256);
    Axis& a = out.axis[c];
    a.grid.resize(g);
    for (int i = 0; i < g; ++i) a.grid[i] = (i + 0.5) * extent / g - 0.5;
    Eigen::MatrixXd k(g, g);
    for (int i = 0; i < g; ++i) {
      for (int j = 0; j < g; ++j) {
        const double z = (a.grid[i] - a.grid[j]) / length_px;
        k(i, j) = std::exp(-0.5 * z * z);
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(k);
    if (eig.info() != Eigen::Success) return out;
    const double largest = eig.eigenvalues().maxCoeff();
    top[static_cast<size_t>(c)] = largest / g;
    std::vector<int> keep;
    for (int m = g - 1; m >= 0; --m) {
      if (eig.eigenvalues()[m] >= 1e-6 * largest) keep.push_back(m);
    }
    a.vectors.resize(g, static_cast<long>(keep.size()));
    a.mu.resize(static_cast<long>(keep.size()));
    for (size_t m = 0; m < keep.size(); ++m) {
      a.vectors.col(static_cast<long>(m)) = eig.eigenvectors().col(keep[m]);
      a.mu[static_cast<long>(m)] = eig.eigenvalues()[keep[m]];
    }
  }
  // The two-dimensional modes psi_a(x) psi_b(y) down to 1e-6 of the largest lambda_a lambda_b.
  const double gx = static_cast<double>(out.axis[0].grid.size()), gy = static_cast<double>(out.axis[1].grid.size());
  for (long i = 0; i < out.axis[0].mu.size(); ++i) {
    for (long j = 0; j < out.axis[1].mu.size(); ++j) {
      if (out.axis[0].mu[i] / gx * out.axis[1].mu[j] / gy >= 1e-6 * top[0] * top[1]) out.modes.emplace_back(i, j);
    }
  }
  if (out.modes.size() > kMaxModes) return out;
  const long m = static_cast<long>(out.modes.size());
  out.lambda.resize(m);
  for (long k = 0; k < m; ++k) {
    const auto [i, j] = out.modes[static_cast<size_t>(k)];
    out.lambda[k] = out.axis[0].mu[i] / gx * out.axis[1].mu[j] / gy;
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0, 1);
  for (size_t f = 0; f < 2; ++f) {
    Eigen::MatrixXd& g = out.normals[f];
    g.resize(m, count);
    for (long d = 0; d < count; ++d) {
      for (long k = 0; k < m; ++k) g(k, d) = unit(rng);
    }
    // The field's mean square over the imager: sum lambda_k g_k^2 (the modes are orthonormal there).
    out.inverse_rms[f] = (out.lambda.transpose() * g.cwiseAbs2()).cwiseSqrt().cwiseInverse();
  }
  out.ok = true;
  return out;
}

Eigen::MatrixXd NormalisedField::Respond(const std::vector<Eigen::Vector2d>& points,
                                         const std::array<Eigen::MatrixXd, 2>& weights,
                                         Eigen::VectorXd* gaussian_sd) const {
  const long n = static_cast<long>(points.size()), rows = weights[0].rows();
  if (!ok || weights[1].rows() != rows || weights[0].cols() != n || weights[1].cols() != n) {
    throw Error("normalised field", fmt::format("weights of {} and {} points", weights[0].cols(), n), "");
  }
  // Each axis's modes at the points: psi(p) = sqrt(g) sum_i k(p, x_i) v_i / mu (Nystrom; at a cell centre its v).
  std::array<Eigen::MatrixXd, 2> at;
  for (int c = 0; c < 2; ++c) {
    const Axis& a = axis[c];
    const long g = a.grid.size();
    Eigen::MatrixXd kp(n, g);
    for (long p = 0; p < n; ++p) {
      for (long i = 0; i < g; ++i) {
        const double z = (points[static_cast<size_t>(p)][c] - a.grid[i]) / length_px;
        kp(p, i) = std::exp(-0.5 * z * z);
      }
    }
    at[static_cast<size_t>(c)] =
        std::sqrt(static_cast<double>(g)) * (kp * a.vectors) * a.mu.cwiseInverse().asDiagonal();
  }
  const long m = lambda.size();
  Eigen::MatrixXd psi(n, m);
  for (long k = 0; k < m; ++k) {
    const auto [i, j] = modes[static_cast<size_t>(k)];
    psi.col(k) = at[0].col(i).cwiseProduct(at[1].col(j));
  }
  // Row r's response to coordinate c's field sum_k sqrt(lambda_k) g_k psi_k: C_c g, C_c = W_c psi sqrt(lambda).
  const Eigen::VectorXd root = lambda.cwiseSqrt();
  Eigen::MatrixXd draws = Eigen::MatrixXd::Zero(rows, normals[0].cols());
  Eigen::VectorXd sd2 = Eigen::VectorXd::Zero(rows);
  for (size_t f = 0; f < 2; ++f) {
    const Eigen::MatrixXd c = (weights[f] * psi) * root.asDiagonal();
    sd2 += c.rowwise().squaredNorm();
    draws += (c * normals[f]) * inverse_rms[f].asDiagonal();
  }
  if (gaussian_sd) *gaussian_sd = sd2.cwiseSqrt();
  return draws;
}

}  // namespace curvecheck
