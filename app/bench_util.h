// Small helpers shared by the `bench` subcommands.
#pragma once

#include <algorithm>
#include <vector>

namespace curvecheck::app {

// The median (the mean of the middle two for an even count); 0 for none.
inline double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace curvecheck::app
