// Coverage factors of the screen fit's uncertainty budget (analysis/screen_fit.h): Student's t, and the
// convolution of the budget's normal part with its rectangular row and its sampled row (CoverageFactor).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis/screen_fit.h"
#include "core/error.h"

namespace curvecheck {
namespace {

// The standard normal density.
double NormalDensity(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2 * 3.14159265358979323846); }

// The standard normal quantile: Newton on 0.5 erfc(-z/sqrt 2) = p from z = 0 (monotone, converges in < 10 steps
// for 1e-12 < p < 1 - 1e-12).
double NormalQuantile(double p) {
  double z = 0;
  for (int i = 0; i < 100; ++i) {
    const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
    const double pdf = NormalDensity(z);
    const double step = (cdf - p) / std::max(pdf, 1e-300);
    z -= step;
    if (std::abs(step) < 1e-14) break;
  }
  return z;
}

}  // namespace

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

const char* RowDistributionName(RowDistribution d) {
  switch (d) {
    case RowDistribution::kRectangular: return "rectangular";
    case RowDistribution::kSampled: return "sampled";
    case RowDistribution::kNormal: break;
  }
  return "normal";
}

double CoverageFactor(double p, const std::vector<CoverageRow>& rows, double* normal_dof) {
  if (!(p > 0 && p < 1)) throw Error("coverage factor", fmt::format("coverage probability {} is not in (0, 1)", p), "");
  // The largest rectangular row stays rectangular, the largest sampled row sampled; every other row goes to the
  // normal part.
  const CoverageRow *rect = nullptr, *sampled = nullptr;
  for (const CoverageRow& r : rows) {
    if (!(std::isfinite(r.u) && r.u >= 0)) {
      throw Error("coverage factor", fmt::format("a row's standard uncertainty is {}", r.u), "");
    }
    if (r.distribution == RowDistribution::kRectangular && r.u > 0 && (!rect || r.u > rect->u)) rect = &r;
    if (r.distribution == RowDistribution::kSampled && r.draws && !r.draws->empty() && r.u > 0 &&
        (!sampled || r.u > sampled->u)) {
      sampled = &r;
    }
  }
  double var_n = 0, denominator = 0;
  for (const CoverageRow& r : rows) {
    if (&r == rect || &r == sampled) continue;
    var_n += r.u * r.u;
    if (std::isfinite(r.dof)) denominator += std::pow(r.u, 4) / std::max(1.0, r.dof);
  }
  const double dof =
      denominator > 0 ? std::max(1.0, var_n * var_n / denominator) : std::numeric_limits<double>::infinity();
  if (normal_dof) *normal_dof = dof;
  const double t = StudentTCoverageFactor(p, dof);
  const double a = rect ? std::sqrt(3.0) * rect->u : 0;
  const double us = sampled ? sampled->u : 0;
  const double uc = std::sqrt(var_n + a * a / 3 + us * us);
  if (!(uc > 0)) return t;
  const double s = std::sqrt(var_n) * t / NormalQuantile(0.5 + 0.5 * p);
  const bool has_rect = a > 1e-12 * uc, has_normal = s > 1e-12 * uc;
  if (!sampled || us <= 1e-12 * uc) {
    if (!has_rect) return t;
    if (!has_normal) return p * a / uc;
  }
  // The distribution function of N(0, s^2) + U(-a, a): (s / 2a) [G((y + a)/s) - G((y - a)/s)] with
  // G(t) = t Phi(t) + phi(t) (the integral of Phi); Phi(y / s) without the rectangle, the rectangle's without the
  // normal part, a step without either.
  const auto G = [](double x) {
    return x * 0.5 * std::erfc(-x / std::sqrt(2.0)) + NormalDensity(x);
  };
  const auto cdf = [&](double y) {
    if (has_rect && has_normal) return s / (2 * a) * (G((y + a) / s) - G((y - a) / s));
    if (has_rect) return std::clamp((y + a) / (2 * a), 0.0, 1.0);
    if (has_normal) return 0.5 * std::erfc(-y / (s * std::sqrt(2.0)));
    return y >= 0 ? 1.0 : 0.0;
  };
  // P(|x + Y| <= c) = F(c - x) - F(-c - x) for Y symmetric, averaged over the sampled row's draws x (the same for
  // -x); x = 0 without one. By G(-t) = G(t) - t this is (s/a)[G((c+a)/s) - G((c-a)/s)] - 1 at x = 0.
  const std::vector<double> zero = {0.0};
  const std::vector<double>& draws = sampled && us > 1e-12 * uc ? *sampled->draws : zero;
  double largest = 0;
  for (double x : draws) largest = std::max(largest, std::abs(x));
  const auto inside = [&](double c) {
    double sum = 0;
    for (double x : draws) sum += cdf(c - us * std::abs(x)) - cdf(-c - us * std::abs(x));
    return sum / static_cast<double>(draws.size());
  };
  // inside(c) = p by the Illinois method (regula falsi that halves a stale end's value; bisection where the
  // secant leaves the bracket): some ten evaluations where bisection took forty-five, each a pass over the draws.
  double lo = 0, hi = us * largest + a + 10 * s;  // inside(hi) > 1 - 1e-20
  double f_lo = inside(lo) - p, f_hi = inside(hi) - p;
  int kept = 0;  // which end the last two steps kept: -1 lo, +1 hi
  for (int i = 0; i < 200 && hi - lo > 1e-12 * uc; ++i) {
    double c = f_hi > f_lo ? (lo * f_hi - hi * f_lo) / (f_hi - f_lo) : 0.5 * (lo + hi);
    if (!(c > lo && c < hi)) c = 0.5 * (lo + hi);
    const double f = inside(c) - p;
    if (f < 0) {
      lo = c, f_lo = f;
      if (kept == 1) f_hi *= 0.5;
      kept = 1;
    } else {
      hi = c, f_hi = f;
      if (kept == -1) f_lo *= 0.5;
      kept = -1;
    }
  }
  return 0.5 * (lo + hi) / uc;
}

}  // namespace curvecheck
