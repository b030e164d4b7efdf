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

// The white level of a photo of a pattern: the 99th percentile (rank n * 99 / 100, by nth_element) of its local
// levels (a small window's mean, or a gray closing's value); the brightest 1% are left to glints and clipped
// noise. 0 for none. The bright areas (white squares, where moire, colour aliasing and the display's gaps are
// measured) are the levels above kBrightOfWhite of it: an edge through a window takes its mean to about half the
// white level.
float WhiteLevel(std::vector<float> levels);
inline constexpr double kBrightOfWhite = 0.6;

}  // namespace curvecheck
