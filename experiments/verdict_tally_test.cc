#include "experiments/verdict_tally.h"

#include <gtest/gtest.h>

namespace curvecheck::experiments {
namespace {

// Reference values: the Wilson score interval's closed form at z = 1.959964, evaluated independently (Python).
TEST(VerdictTally, WilsonIntervalMatchesReferenceValues) {
  BinomialInterval ci = WilsonInterval(0, 10);
  EXPECT_EQ(ci.lo, 0);
  EXPECT_NEAR(ci.hi, 0.27753, 1e-5);
  ci = WilsonInterval(5, 10);
  EXPECT_NEAR(ci.lo, 0.23659, 1e-5);
  EXPECT_NEAR(ci.hi, 0.76341, 1e-5);
  ci = WilsonInterval(60, 60);
  EXPECT_NEAR(ci.lo, 0.93983, 1e-5);
  EXPECT_EQ(ci.hi, 1);
  ci = WilsonInterval(0, 60);
  EXPECT_NEAR(ci.hi, 0.06017, 1e-5);
  ci = WilsonInterval(0, 0);
  EXPECT_EQ(ci.lo, 0);
  EXPECT_EQ(ci.hi, 1);
}

TEST(VerdictTally, CountsAndRates) {
  VerdictCounts c;
  for (VerdictColumn v : {VerdictColumn::kPass, VerdictColumn::kPass, VerdictColumn::kFail,
                          VerdictColumn::kInconclusive, VerdictColumn::kNone}) {
    c.Add(v);
  }
  EXPECT_EQ(c.pass, 2);
  EXPECT_EQ(c.Verdicts(), 4);
  EXPECT_EQ(c.Total(), 5);
  VerdictCounts d;
  d.Add(c);
  d.Add(VerdictColumn::kFail);
  EXPECT_EQ(d.fail, 2);
  EXPECT_EQ(RateText(0, 10), "0/10 = 0.0% [0.0%, 27.8%]");
  EXPECT_EQ(RateText(1, 0), "-");
  EXPECT_STREQ(VerdictColumnName(VerdictColumn::kInconclusive), "inconclusive");
}

}  // namespace
}  // namespace curvecheck::experiments
