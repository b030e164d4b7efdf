#include "experiments/verdict_tally.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace curvecheck::experiments {

BinomialInterval WilsonInterval(int k, int n, double z) {
  if (n <= 0) return {0, 1};
  const double nn = n, p = static_cast<double>(k) / nn, z2 = z * z;
  const double centre = (p + z2 / (2 * nn)) / (1 + z2 / nn);
  const double half = z / (1 + z2 / nn) * std::sqrt(p * (1 - p) / nn + z2 / (4 * nn * nn));
  // At k = 0 and k = n the bound is exactly 0 and 1 (rounding would leave 1e-17).
  return {k == 0 ? 0.0 : std::max(0.0, centre - half), k == n ? 1.0 : std::min(1.0, centre + half)};
}

const char* VerdictColumnName(VerdictColumn c) {
  switch (c) {
    case VerdictColumn::kPass: return "pass";
    case VerdictColumn::kFail: return "fail";
    case VerdictColumn::kInconclusive: return "inconclusive";
    case VerdictColumn::kNone: return "none";
  }
  return "none";
}

void VerdictCounts::Add(VerdictColumn c) {
  switch (c) {
    case VerdictColumn::kPass: ++pass; break;
    case VerdictColumn::kFail: ++fail; break;
    case VerdictColumn::kInconclusive: ++inconclusive; break;
    case VerdictColumn::kNone: ++none; break;
  }
}

void VerdictCounts::Add(const VerdictCounts& o) {
  pass += o.pass;
  fail += o.fail;
  inconclusive += o.inconclusive;
  none += o.none;
}

std::string RateText(int k, int n) {
  if (n <= 0) return "-";
  const BinomialInterval ci = WilsonInterval(k, n);
  return fmt::format("{}/{} = {:.1f}% [{:.1f}%, {:.1f}%]", k, n, 100.0 * k / n, 100 * ci.lo, 100 * ci.hi);
}

}  // namespace curvecheck::experiments
