#include "experiments/validity_stats.h"

#include <algorithm>
#include <cmath>
#include <random>

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
  double sum_error = 0, sum_sigma = 0, sum_net = 0;
  for (const IntervalSample& x : samples) {
    if (!x.Valid()) continue;
    ++s.n;
    sum_error += x.estimate - x.truth;
    sum_net += x.estimate - x.truth - x.known_error;
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
  const double mean_net = sum_net / s.n;
  s.net_bias_sigma = mean_net / s.mean_sigma;
  if (s.n >= 2) {
    double ss = 0, ss_net = 0;
    for (const IntervalSample& x : samples) {
      if (!x.Valid()) continue;
      ss += std::pow(x.estimate - x.truth - s.mean_error, 2);
      ss_net += std::pow(x.estimate - x.truth - x.known_error - mean_net, 2);
    }
    s.sd_error = std::sqrt(ss / (s.n - 1));
    s.bias_sigma_se = s.sd_error / std::sqrt(static_cast<double>(s.n)) / s.mean_sigma;
    s.net_bias_sigma_se = std::sqrt(ss_net / (s.n - 1)) / std::sqrt(static_cast<double>(s.n)) / s.mean_sigma;
    s.scatter_ratio = s.sd_error / s.mean_sigma;
  }
  return s;
}

bool ValidityRule::Holds(const CoverageStats& s) const {
  const double c = s.Coverage95();
  return s.n > 0 && c >= coverage95_lo && c <= coverage95_hi && std::abs(s.net_bias_sigma) < max_bias_sigma;
}

bool ValidityRule::CoverageConsistent(const CoverageStats& s) const {
  return s.n > 0 && s.wilson95.lo <= coverage95_hi && s.wilson95.hi >= coverage95_lo;
}

ValidityRule::Outcome ValidityRule::Classify(const CoverageStats& s) const {
  if (Holds(s)) return Outcome::kMeets;
  if (CoverageConsistent(s) && std::abs(s.net_bias_sigma) < max_bias_sigma) return Outcome::kConsistent;
  return Outcome::kFails;
}

void OutcomeCounts::Add(ValidityRule::Outcome o) {
  switch (o) {
    case ValidityRule::Outcome::kMeets:
      ++meets;
      break;
    case ValidityRule::Outcome::kConsistent:
      ++consistent;
      break;
    case ValidityRule::Outcome::kFails:
      ++fails;
      break;
  }
}

RuleReference NominalRuleReference(const std::vector<int>& samples_per_cell, const ValidityRule& rule,
                                   int grids, uint64_t seed, int observed_meets, int observed_fails) {
  RuleReference r;
  r.grids = std::max(grids, 1);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0, 1);
  std::vector<int> meets;
  int at_most = 0, at_least = 0;
  std::vector<IntervalSample> samples;
  for (int g = 0; g < r.grids; ++g) {
    OutcomeCounts grid;
    for (int n : samples_per_cell) {
      samples.clear();
      for (int i = 0; i < n; ++i) samples.push_back(SymmetricSample(unit(rng), 0, 1));
      grid.Add(rule.Classify(SummariseCoverage(samples)));
    }
    r.meets += grid.meets;
    r.consistent += grid.consistent;
    r.fails += grid.fails;
    meets.push_back(grid.meets);
    at_most += observed_meets >= 0 && grid.meets <= observed_meets ? 1 : 0;
    at_least += observed_fails >= 0 && grid.fails >= observed_fails ? 1 : 0;
  }
  r.meets /= r.grids;
  r.consistent /= r.grids;
  r.fails /= r.grids;
  std::sort(meets.begin(), meets.end());
  r.meets_p05 = meets[static_cast<size_t>(0.05 * (r.grids - 1))];
  r.meets_p95 = meets[static_cast<size_t>(0.95 * (r.grids - 1))];
  if (observed_meets >= 0) r.p_meets_at_most = static_cast<double>(at_most) / r.grids;
  if (observed_fails >= 0) r.p_fails_at_least = static_cast<double>(at_least) / r.grids;
  return r;
}

}  // namespace curvecheck::experiments
