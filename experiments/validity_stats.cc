#include "experiments/validity_stats.h"

#include <cmath>

namespace curvecheck::experiments {

bool IntervalSample::Valid() const {
  return std::isfinite(estimate) && std::isfinite(truth) && std::isfinite(sigma) && sigma > 0 && lo95 <= hi95;
}

bool IntervalSample::In68() const {
  if (std::isfinite(lo68) && std::isfinite(hi68)) return truth >= lo68 && truth <= hi68;
  return std::abs(estimate - truth) <= sigma;
}

bool IntervalSample::In95() const { return truth >= lo95 && truth <= hi95; }

IntervalSample SymmetricSample(double estimate, double truth, double sigma, double k95, double k68) {
  const double k = std::isfinite(k95) ? k95 : 1.959963984540054, h = std::isfinite(k68) ? k68 : 1;
  return {estimate, truth, sigma, estimate - k * sigma, estimate + k * sigma, estimate - h * sigma,
          estimate + h * sigma};
}

double CoverageStats::Coverage68() const {
  return n > 0 ? static_cast<double>(k68) / n : std::numeric_limits<double>::quiet_NaN();
}

double CoverageStats::Coverage95() const {
  return n > 0 ? static_cast<double>(k95) / n : std::numeric_limits<double>::quiet_NaN();
}

CoverageStats SummariseCoverage(const std::vector<IntervalSample>& samples) {
  CoverageStats s;
  double sum_error = 0, sum_sigma = 0;
  for (const IntervalSample& x : samples) {
    if (!x.Valid()) continue;
    ++s.n;
    sum_error += x.estimate - x.truth;
    sum_sigma += x.sigma;
    s.k68 += x.In68() ? 1 : 0;
    s.k95 += x.In95() ? 1 : 0;
  }
  s.wilson68 = WilsonInterval(s.k68, s.n);
  s.wilson95 = WilsonInterval(s.k95, s.n);
  if (s.n == 0) return s;
  s.mean_error = sum_error / s.n;
  s.mean_sigma = sum_sigma / s.n;
  s.bias_sigma = s.mean_error / s.mean_sigma;
  if (s.n >= 2) {
    double ss = 0;
    for (const IntervalSample& x : samples) {
      if (x.Valid()) ss += std::pow(x.estimate - x.truth - s.mean_error, 2);
    }
    s.sd_error = std::sqrt(ss / (s.n - 1));
    s.bias_sigma_se = s.sd_error / std::sqrt(static_cast<double>(s.n)) / s.mean_sigma;
    s.scatter_ratio = s.sd_error / s.mean_sigma;
  }
  return s;
}

bool ValidityRule::Holds(const CoverageStats& s) const {
  const double c = s.Coverage95();
  return s.n > 0 && c >= coverage95_lo && c <= coverage95_hi && std::abs(s.bias_sigma) < max_bias_sigma;
}

bool ValidityRule::CoverageConsistent(const CoverageStats& s) const {
  return s.n > 0 && s.wilson95.lo <= coverage95_hi && s.wilson95.hi >= coverage95_lo;
}

}  // namespace curvecheck::experiments
