#include "core/stats.h"

#include <gtest/gtest.h>

#include <cmath>

namespace curvecheck {
namespace {

TEST(Stats, MedianOfOddAndEvenCountsAndNone) {
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(Median({}), 0);
}

TEST(Stats, PercentileInterpolatesBetweenClosestRanks) {
  // NumPy: np.percentile([1,2,3,4,5,6,7,8,9,10], 95) = 9.55; 0 -> min, 100 -> max.
  std::vector<double> v = {10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
  EXPECT_NEAR(Percentile(v, 95), 9.55, 1e-12);
  EXPECT_DOUBLE_EQ(Percentile(v, 0), 1);
  EXPECT_DOUBLE_EQ(Percentile(v, 100), 10);
  EXPECT_DOUBLE_EQ(Percentile(v, 150), 10);
  EXPECT_DOUBLE_EQ(Percentile({7}, 37), 7);
}

TEST(Stats, WhiteLevelLeavesTheBrightestPercentOut) {
  // 0..999 shuffled, with 10 glints (1%) at 5000: rank 1010 * 99 / 100 = 999 of the sorted values, the top non-glint.
  std::vector<float> v;
  for (int i = 0; i < 1000; ++i) v.push_back(static_cast<float>((i * 7919) % 1000));
  for (int i = 0; i < 10; ++i) v.push_back(5000);
  EXPECT_FLOAT_EQ(WhiteLevel(v), 999);
  EXPECT_FLOAT_EQ(WhiteLevel({3}), 3);
  EXPECT_FLOAT_EQ(WhiteLevel({}), 0);
}

TEST(Stats, Rms) {
  EXPECT_DOUBLE_EQ(Rms({3, 4}), std::sqrt(12.5));
  EXPECT_DOUBLE_EQ(Rms({}), 0);
}

}  // namespace
}  // namespace curvecheck
