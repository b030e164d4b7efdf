// The statistics of `bench validity` (bench_validity.h): is a reported interval honest? Over seeded trials of
// one grid cell, each giving an estimate, its reported standard uncertainty sigma and 95% interval, and the
// truth: bias in units of sigma, empirical scatter against sigma, and the coverage of the 68% and 95%
// intervals with Wilson 95% intervals on the rates (metrology.md section 1: 95% intervals must hold the truth
// 90-98% of the time, 68% ones 63-73%; bias is reported in sigmas).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "experiments/verdict_tally.h"

namespace curvecheck::experiments {

// One trial's estimate of a scalar against its truth, with what the method reported for it.
struct IntervalSample {
  double estimate = std::numeric_limits<double>::quiet_NaN();
  double truth = std::numeric_limits<double>::quiet_NaN();
  double sigma = std::numeric_limits<double>::quiet_NaN();  // reported standard uncertainty, > 0
  // The reported 95% interval (may be asymmetric, or reach +inf: a radius from a curvature interval).
  double lo95 = std::numeric_limits<double>::quiet_NaN(), hi95 = std::numeric_limits<double>::quiet_NaN();
  // The reported 68% interval; NaN (not reported, e.g. a row of an older bench): estimate +- sigma.
  double lo68 = std::numeric_limits<double>::quiet_NaN(), hi68 = std::numeric_limits<double>::quiet_NaN();
  // A part of the error whose mean is known to be zero and whose value the bench knows: its own draw of an input
  // the interval must cover (bench validity: the true pixel pitch, drawn within the stated tolerance, scales the
  // whole scene, so it moves the estimate by truth x (1 / pitch_scale - 1) exactly). The coverage counts it; the
  // bias is estimated with it taken out as well (a control variate: the same expectation, less scatter).
  double known_error = 0;

  // Usable: finite estimate, truth and sigma > 0, and lo95 <= hi95 (NaN bounds are not).
  bool Valid() const;
  // The 68% interval is [lo68, hi68] when reported, else estimate +- sigma (coverage factor 1: 68.3% for a
  // Gaussian); the 95% one [lo95, hi95].
  bool In68() const;
  bool In95() const;
};

// A sample whose 95% interval is estimate +- k95 sigma and 68% interval estimate +- k68 sigma (a camera position
// coordinate: the budget's coverage factors for it; not finite or absent: the normal 1.959964 and 1).
IntervalSample SymmetricSample(double estimate, double truth, double sigma,
                               double k95 = std::numeric_limits<double>::quiet_NaN(),
                               double k68 = std::numeric_limits<double>::quiet_NaN());

struct CoverageStats {
  int n = 0;  // valid samples: everything below is over them
  // error = estimate - truth. bias_sigma = mean(error) / mean(sigma); its standard error
  // sd(error) / sqrt(n) / mean(sigma) (NaN for n < 2). scatter_ratio = sd(error) / mean(sigma): 1 when the
  // reported sigma is the real scatter (NaN for n < 2). sd with n - 1.
  double mean_error = std::numeric_limits<double>::quiet_NaN();
  double sd_error = std::numeric_limits<double>::quiet_NaN();
  double mean_sigma = std::numeric_limits<double>::quiet_NaN();
  double bias_sigma = std::numeric_limits<double>::quiet_NaN();
  double bias_sigma_se = std::numeric_limits<double>::quiet_NaN();
  double scatter_ratio = std::numeric_limits<double>::quiet_NaN();
  // The bias with the samples' known errors taken out: mean(error - known_error) / mean(sigma), and its standard
  // error sd(error - known_error) / sqrt(n) / mean(sigma). An estimate of the same bias (known_error has mean 0)
  // with less scatter where the known part is large; equal to bias_sigma where it is 0. The rule reads this one.
  double net_bias_sigma = std::numeric_limits<double>::quiet_NaN();
  double net_bias_sigma_se = std::numeric_limits<double>::quiet_NaN();
  int k68 = 0, k95 = 0;                 // samples whose 68% / 95% interval holds the truth
  BinomialInterval wilson68, wilson95;  // Wilson 95% intervals of the coverage rates k / n

  double Coverage68() const;  // k68 / n, NaN for n = 0
  double Coverage95() const;
};

// The statistics of the valid samples (invalid ones are left out: the caller counts them as failed trials).
CoverageStats SummariseCoverage(const std::vector<IntervalSample>& samples);

// The acceptance rule for a cell (issue 16, "Done when"): the 95% coverage within [coverage95_lo,
// coverage95_hi] and |bias| below max_bias_sigma (CoverageStats::net_bias_sigma), on point estimates, with at least
// one valid sample.
struct ValidityRule {
  double coverage95_lo = 0.90, coverage95_hi = 0.98;
  double max_bias_sigma = 0.5;

  bool Holds(const CoverageStats& s) const;
  // Whether the Wilson interval of the 95% coverage overlaps [coverage95_lo, coverage95_hi]: a cell that
  // fails the rule on its point estimate may still be consistent with it at this trial count (20 trials of a
  // perfect 95% interval give 20/20 = 100% 36% of the time).
  bool CoverageConsistent(const CoverageStats& s) const;

  // The bench's three classes of a cell: meets the rule on its point estimates; fails it on its point
  // estimates but its coverage's Wilson interval overlaps the band and |bias| is below the bound ("ok?");
  // fails.
  enum class Outcome { kMeets, kConsistent, kFails };
  Outcome Classify(const CoverageStats& s) const;
};

// How many cells fall in each of the rule's classes.
struct OutcomeCounts {
  int meets = 0, consistent = 0, fails = 0;
  void Add(ValidityRule::Outcome o);
};

// What the rule gives, at the bench's own sample counts, a method whose intervals are exactly right: errors
// N(0, sigma^2), 95% interval +- 1.959964 sigma, 68% +- sigma. At 20 samples a cell of such a method meets
// the rule only about 55% of the time (the 95% coverage must be 18 or 19 of 20: 57%; |mean z| < 0.5: 97.5%),
// and at 9 samples |mean z| exceeds 0.5 13% of the time. Read a bench's counts against these, not against
// "every cell". Seeded Monte Carlo over whole grids, each cell drawn with its own count (0: a cell without
// samples, classed kFails as the bench does).
struct RuleReference {
  int grids = 0;
  double meets = 0, consistent = 0, fails = 0;  // expected number of cells of each class
  int meets_p05 = 0, meets_p95 = 0;             // 5th and 95th percentile of the number meeting the rule
  // The share of grids with at most `observed_meets` meeting / at least `observed_fails` failing (one-sided
  // p-values of the bench's counts under the exact method; 1 when not asked).
  double p_meets_at_most = 1, p_fails_at_least = 1;
};
RuleReference NominalRuleReference(const std::vector<int>& samples_per_cell, const ValidityRule& rule,
                                   int grids, uint64_t seed, int observed_meets = -1,
                                   int observed_fails = -1);

}  // namespace curvecheck::experiments
