// Order statistics of samples (timings of repeated runs, residual magnitudes). Values are taken by copy and
// sorted; an empty sample gives 0 (a table row with no runs), never a throw.
#pragma once

#include <vector>

namespace curvecheck {

// The median: the middle value, or the mean of the middle two for an even count; 0 for none.
double Median(std::vector<double> values);

// The p-th percentile, p in [0, 100], by linear interpolation between closest ranks (the "R-7"/NumPy default
// definition: rank (n - 1) p / 100); 0 for none. p outside [0, 100] is clamped.
double Percentile(std::vector<double> values, double p);

// Root mean square; 0 for none.
double Rms(const std::vector<double>& values);

}  // namespace curvecheck
