// Counting verdicts against the truth for `bench verdict` (bench_verdict.h): the confusion matrix's cells and the
// binomial intervals of its rates.
#pragma once

#include <string>

namespace curvecheck::experiments {

// A two-sided binomial confidence interval for a proportion.
struct BinomialInterval {
  double lo = 0, hi = 1;
};

// Wilson's score interval for k successes in n trials at the two-sided level of the normal quantile z (1.96:
// 95%). Unlike the normal approximation it stays inside [0, 1] and is not degenerate at k = 0 or k = n (0 of
// 60 gives [0, 6.0%]). n = 0 gives [0, 1]. Wilson, E. B. (1927) JASA 22, 209-212.
BinomialInterval WilsonInterval(int k, int n, double z = 1.959963984540054);

// The columns of the confusion matrix: the verification's three verdicts, and no verdict at all (the photo was
// rejected: pattern not found, too few features).
enum class VerdictColumn { kPass, kFail, kInconclusive, kNone };
const char* VerdictColumnName(VerdictColumn c);  // "pass", "fail", "inconclusive", "none"

// One row of the confusion matrix.
struct VerdictCounts {
  int pass = 0, fail = 0, inconclusive = 0, none = 0;

  void Add(VerdictColumn c);
  void Add(const VerdictCounts& other);
  int Verdicts() const { return pass + fail + inconclusive; }  // trials that reached a verdict
  int Total() const { return Verdicts() + none; }
};

// "k/n = r% [lo%, hi%]" with the Wilson 95% interval; "-" for n = 0.
std::string RateText(int k, int n);

}  // namespace curvecheck::experiments
