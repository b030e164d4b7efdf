// Small numeric helpers shared by the geometry code.
#pragma once

#include <cmath>

namespace curvecheck {

// sin(x)/x, exact to double precision for all x including 0 (used to write cylinder formulas that stay
// accurate as the curvature goes to zero).
inline double Sinc(double x) {
  if (std::abs(x) < 1e-4) {
    const double x2 = x * x;
    return 1 - x2 / 6 * (1 - x2 / 20);  // error below x^6/5040 < 2e-28
  }
  return std::sin(x) / x;
}

constexpr double kDegPerRad = 57.29577951308232;
constexpr double kRadPerDeg = 1 / kDegPerRad;

}  // namespace curvecheck
