// The statistics of `bench validity` (validity_stats.h) on hand-made samples whose answers are known, and on
// seeded Gaussian samples whose sigma is right, too small, or hides a bias.
#include "experiments/validity_stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace curvecheck::experiments {
namespace {

TEST(ValidityStats, CountsCoverageOfBothIntervalsAndLeavesInvalidSamplesOut) {
  // Truth 1000 mm, sigma 2 mm, the reported 95% interval asymmetric as a radius from a curvature interval is.
  const std::vector<IntervalSample> samples = {
      {1001, 1000, 2, 997, 1005},     // error +1: inside both
      {1003, 1000, 2, 999, 1007},     // +3: outside +-sigma, inside the 95% interval
      {1006, 1000, 2, 1001.5, 1011},  // +6: outside both
      {998, 1000, 2, 994, 1002},      // -2: exactly sigma away: inside the 68% interval (|e| <= sigma)
      {995, 1000, 2, 991, INFINITY},  // -5: 95% interval reaching +inf holds the truth
      {NAN, 1000, 2, 990, 1010},      // no estimate: left out
      {1000, 1000, 0, 990, 1010},     // sigma 0: left out
      {1000, 1000, 2, NAN, NAN},      // no interval: left out
  };
  const CoverageStats s = SummariseCoverage(samples);
  EXPECT_EQ(s.n, 5);
  EXPECT_EQ(s.k68, 2);
  EXPECT_EQ(s.k95, 4);
  EXPECT_DOUBLE_EQ(s.Coverage68(), 0.4);
  EXPECT_DOUBLE_EQ(s.Coverage95(), 0.8);
  // errors +1, +3, +6, -2, -5: mean 0.6, sd sqrt(((0.4)^2 + 2.4^2 + 5.4^2 + 2.6^2 + 5.6^2) / 4) = sqrt(73.2 /
  // 4).
  EXPECT_DOUBLE_EQ(s.mean_error, 0.6);
  EXPECT_DOUBLE_EQ(s.mean_sigma, 2);
  EXPECT_DOUBLE_EQ(s.bias_sigma, 0.3);
  EXPECT_NEAR(s.sd_error, std::sqrt(73.2 / 4), 1e-12);
  EXPECT_NEAR(s.scatter_ratio, std::sqrt(73.2 / 4) / 2, 1e-12);
  EXPECT_NEAR(s.bias_sigma_se, std::sqrt(73.2 / 4) / std::sqrt(5.0) / 2, 1e-12);
  // Wilson 95% of 4/5, by the closed form evaluated independently (Python): [0.37553, 0.96378].
  EXPECT_NEAR(s.wilson95.lo, 0.37553, 1e-5);
  EXPECT_NEAR(s.wilson95.hi, 0.96378, 1e-5);
}

TEST(ValidityStats, EmptyAndSingleSamples) {
  CoverageStats s = SummariseCoverage({});
  EXPECT_EQ(s.n, 0);
  EXPECT_TRUE(std::isnan(s.Coverage95()));
  EXPECT_TRUE(std::isnan(s.bias_sigma));
  EXPECT_EQ(s.wilson95.lo, 0);
  EXPECT_EQ(s.wilson95.hi, 1);
  EXPECT_FALSE(ValidityRule().Holds(s));
  EXPECT_FALSE(ValidityRule().CoverageConsistent(s));
  s = SummariseCoverage({SymmetricSample(10.5, 10, 1)});
  EXPECT_EQ(s.n, 1);
  EXPECT_EQ(s.k68, 1);
  EXPECT_EQ(s.k95, 1);
  EXPECT_DOUBLE_EQ(s.bias_sigma, 0.5);
  EXPECT_TRUE(std::isnan(s.scatter_ratio));  // no spread from one sample
  EXPECT_TRUE(std::isnan(s.bias_sigma_se));
}

TEST(ValidityStats, SymmetricSampleUsesTheNormalQuantile) {
  const IntervalSample x = SymmetricSample(0, 1.959, 1);
  EXPECT_TRUE(x.In95());
  EXPECT_FALSE(SymmetricSample(0, 1.961, 1).In95());
  EXPECT_FALSE(x.In68());
  // With the budget's coverage factor (a rectangular row dominating: down to 1.645).
  EXPECT_TRUE(SymmetricSample(0, 1.64, 1, 1.645).In95());
  EXPECT_FALSE(SymmetricSample(0, 1.65, 1, 1.645).In95());
  EXPECT_TRUE(SymmetricSample(0, 1.95, 1, std::numeric_limits<double>::quiet_NaN()).In95());
  // The 68% interval: +- sigma unless a factor is given (a rectangle: 1.18 sigma holds 68%).
  EXPECT_TRUE(SymmetricSample(0, 1.1, 1, 1.645, 1.18).In68());
  EXPECT_FALSE(SymmetricSample(0, 1.1, 1, 1.645).In68());
  // A reported asymmetric 68% interval is used as it is.
  IntervalSample r{10, 11.5, 1, 7, 14, 8.5, 11.6};
  EXPECT_TRUE(r.In68());
  r.hi68 = 11.4;
  EXPECT_FALSE(r.In68());
}

// Seeded Gaussian errors: an honest sigma covers 95% and 68% (within the binomial scatter of 4000 samples:
// +-0.7% and +-1.5% at 2 sigma), scatter ratio 1, no bias; a sigma half the real scatter covers about 68% at
// "95%" (P(|z| < 0.98)) and shows a scatter ratio of 2; a bias of 1 sigma shows as 1 sigma.
TEST(ValidityStats, GaussianSamplesGiveTheExpectedRates) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> z(0, 1);
  const auto run = [&](double scatter, double reported, double offset) {
    std::vector<IntervalSample> samples;
    for (int i = 0; i < 4000; ++i) {
      samples.push_back(SymmetricSample(1000 + offset + scatter * z(rng), 1000, reported));
    }
    return SummariseCoverage(samples);
  };
  CoverageStats s = run(2, 2, 0);
  EXPECT_EQ(s.n, 4000);
  EXPECT_NEAR(s.Coverage95(), 0.95, 0.007);  // +-1.959964 sigma: exactly 95%
  EXPECT_NEAR(s.Coverage68(), 0.6827, 0.015);
  EXPECT_NEAR(s.scatter_ratio, 1, 0.03);
  EXPECT_NEAR(s.bias_sigma, 0, 3 * s.bias_sigma_se);
  EXPECT_NEAR(s.bias_sigma_se, 1 / std::sqrt(4000.0), 0.001);
  EXPECT_TRUE(ValidityRule().Holds(s));
  s = run(2, 1, 0);
  EXPECT_NEAR(s.Coverage95(), 0.6729, 0.015);
  EXPECT_NEAR(s.scatter_ratio, 2, 0.06);
  EXPECT_FALSE(ValidityRule().Holds(s));
  EXPECT_FALSE(ValidityRule().CoverageConsistent(s));
  s = run(2, 2, 2);
  EXPECT_NEAR(s.bias_sigma, 1, 0.05);
  EXPECT_FALSE(ValidityRule().Holds(s));
}

// A known part of the error (the bench's own draw of the true pixel pitch within its tolerance) is counted by the
// coverage and taken out of the bias: the same expectation, a smaller standard error where it is large, and the
// rule reads the net bias. 2000 seeded cells of 20 samples, each error a uniform known part of sd 0.8 sigma plus
// N(0, 0.6^2 sigma^2) (total sd 1: the reported sigma is right): the raw and net biases both have mean 0 (within
// 4 standard errors of their means), their spreads are 1 / sqrt(20) and 0.6 / sqrt(20), and a bias of 0.3
// sigma shows in both.
TEST(ValidityStats, KnownErrorsLeaveTheBiasAndShrinkItsStandardError) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> z(0, 1);
  const double half = 0.8 * std::sqrt(3.0);  // a uniform of sd 0.8
  std::uniform_real_distribution<double> known(-half, half);
  const auto cell = [&](double bias) {
    std::vector<IntervalSample> samples;
    for (int i = 0; i < 20; ++i) {
      const double k = known(rng);
      IntervalSample x = SymmetricSample(100 + bias + k + 0.6 * z(rng), 100, 1);
      x.known_error = k;
      samples.push_back(x);
    }
    return SummariseCoverage(samples);
  };
  constexpr int kCells = 2000;
  double raw = 0, raw2 = 0, net = 0, net2 = 0, se_net = 0;
  for (int c = 0; c < kCells; ++c) {
    const CoverageStats s = cell(0);
    raw += s.bias_sigma, raw2 += s.bias_sigma * s.bias_sigma;
    net += s.net_bias_sigma, net2 += s.net_bias_sigma * s.net_bias_sigma;
    se_net += s.net_bias_sigma_se;
  }
  raw /= kCells, net /= kCells, se_net /= kCells;
  const double sd_raw = std::sqrt(raw2 / kCells - raw * raw), sd_net = std::sqrt(net2 / kCells - net * net);
  EXPECT_NEAR(raw, 0, 4 * sd_raw / std::sqrt(double{kCells}));
  EXPECT_NEAR(net, 0, 4 * sd_net / std::sqrt(double{kCells}));
  EXPECT_NEAR(sd_raw, 1 / std::sqrt(20.0), 0.02);
  EXPECT_NEAR(sd_net, 0.6 / std::sqrt(20.0), 0.012);
  EXPECT_NEAR(se_net, 0.6 / std::sqrt(20.0), 0.012);  // the reported standard error is the spread's
  // A real bias of 0.3 sigma stays in the net bias (mean over the cells), and at 0.7 sigma the rule fails on it.
  double shifted = 0;
  for (int c = 0; c < kCells; ++c) shifted += cell(0.3).net_bias_sigma;
  EXPECT_NEAR(shifted / kCells, 0.3, 4 * sd_net / std::sqrt(double{kCells}));
  int fails = 0;
  for (int c = 0; c < 200; ++c) fails += ValidityRule().Holds(cell(0.7)) ? 0 : 1;
  EXPECT_GT(fails, 190);
}

TEST(ValidityStats, RuleOnPointEstimatesAndOnTheWilsonInterval) {
  // 19 of 20 covered, bias 0: holds. 20 of 20: 100% is above 98%, so the rule fails, but the Wilson interval
  // [83.9%, 100%] overlaps the band: consistent. 15 of 20 (75%, Wilson [53.1%, 88.8%]): neither.
  const auto cell = [](int covered, int n) {
    std::vector<IntervalSample> samples;
    for (int i = 0; i < n; ++i) {
      const double e = (i % 2 ? 1 : -1) * (i < covered ? 0.5 : 3.0);
      samples.push_back(SymmetricSample(100 + e, 100, 1));
    }
    return SummariseCoverage(samples);
  };
  const ValidityRule rule;
  CoverageStats s = cell(19, 20);
  EXPECT_EQ(s.k95, 19);
  EXPECT_TRUE(rule.Holds(s)) << s.bias_sigma;
  s = cell(20, 20);
  EXPECT_FALSE(rule.Holds(s));
  EXPECT_TRUE(rule.CoverageConsistent(s));
  EXPECT_NEAR(s.wilson95.lo, 0.83887, 1e-5);
  s = cell(15, 20);
  EXPECT_FALSE(rule.Holds(s));
  EXPECT_FALSE(rule.CoverageConsistent(s));
  EXPECT_NEAR(s.wilson95.hi, 0.88814, 1e-5);
  EXPECT_EQ(rule.Classify(cell(19, 20)), ValidityRule::Outcome::kMeets);
  EXPECT_EQ(rule.Classify(cell(20, 20)), ValidityRule::Outcome::kConsistent);
  EXPECT_EQ(rule.Classify(cell(15, 20)), ValidityRule::Outcome::kFails);
  // Consistent coverage but a bias beyond the bound on its point estimate: fails.
  std::vector<IntervalSample> biased;
  for (int i = 0; i < 20; ++i) biased.push_back(SymmetricSample(100.6 + (i % 2 ? 0.3 : -0.3), 100, 1));
  EXPECT_EQ(rule.Classify(SummariseCoverage(biased)), ValidityRule::Outcome::kFails);
}

TEST(ValidityStats, ExactIntervalsMeetTheRuleOnlyAsOftenAsTheSampleCountAllows) {
  // Reference values from an independent simulation (numpy, 400000 cells per count, other generator): a cell
  // of N(0, 1) errors with +- 1.96 intervals meets the rule with probability 0.5492 at 20 samples, is
  // consistent without meeting it 0.4232, fails 0.0276; at 9 samples it cannot meet it (8/9 = 89%, 9/9 =
  // 100%) and fails 0.1392 (|mean z| >= 0.5, or 6 or fewer covered); at 5, fails 0.2739. Standard errors
  // here: about 0.0035 at 20000 cells, 0.0049 at 5000.
  const ValidityRule rule;
  RuleReference r = NominalRuleReference(std::vector<int>(20, 20), rule, 1000, 7);
  EXPECT_EQ(r.grids, 1000);
  EXPECT_NEAR(r.meets / 20, 0.5492, 0.012);
  EXPECT_NEAR(r.consistent / 20, 0.4232, 0.012);
  EXPECT_NEAR(r.fails / 20, 0.0276, 0.005);
  EXPECT_NEAR(r.meets + r.consistent + r.fails, 20, 1e-9);
  // The spread of the count over grids: binomial(20, 0.55) has its 5th and 95th percentiles at 7 and 15.
  EXPECT_GE(r.meets_p05, 6);
  EXPECT_LE(r.meets_p05, 8);
  EXPECT_GE(r.meets_p95, 13);
  EXPECT_LE(r.meets_p95, 15);
  r = NominalRuleReference({9, 9, 9, 9, 9}, rule, 1000, 8);
  EXPECT_EQ(r.meets, 0);
  EXPECT_NEAR(r.fails / 5, 0.1392, 0.015);
  r = NominalRuleReference({5}, rule, 5000, 9);
  EXPECT_NEAR(r.fails, 0.2739, 0.02);
  // A cell without samples fails, as in the bench.
  r = NominalRuleReference({0, 20}, rule, 200, 10);
  EXPECT_GE(r.fails, 1);
  // One-sided p-values of observed counts: at most 20 of 20 meeting is certain; at least 0 failing too; at
  // most 0 meeting of twenty 20-sample cells has probability 0.45^20, never seen in 1000 grids.
  r = NominalRuleReference(std::vector<int>(20, 20), rule, 1000, 11, 20, 0);
  EXPECT_EQ(r.p_meets_at_most, 1);
  EXPECT_EQ(r.p_fails_at_least, 1);
  r = NominalRuleReference(std::vector<int>(20, 20), rule, 1000, 11, 0, 20);
  EXPECT_EQ(r.p_meets_at_most, 0);
  EXPECT_EQ(r.p_fails_at_least, 0);
  // Seeded: the same seed gives the same reference.
  EXPECT_EQ(NominalRuleReference({20, 9}, rule, 300, 12).meets,
            NominalRuleReference({20, 9}, rule, 300, 12).meets);
}

}  // namespace
}  // namespace curvecheck::experiments
