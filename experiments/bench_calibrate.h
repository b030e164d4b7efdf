// `curvecheck bench calibrate`: lens-model speed against accuracy (issue 7 item 2c).
//
// The set: the synthetic camera photographs a flat monitor showing a checkerboard through a known lens
// (StrongOpencv8Lens, 640x480: an OPENCV8 truth that OPENCV4 cannot absorb), from the choreography of
// calibrate/truth_comparison.h; the corners are detected once. Each lens model is then calibrated alone (no
// model choice, no cross-validation) --runs times with the same detections. Per model: the median wall time
// of the calibration (mrcal's seeding, solve and uncertainty, the Python start included) and of mrcal's solve
// alone; the recovered model against the truth (CompareWithTruth: RMS px over the imager's 16x12 grid, over
// the observed grid points, and where the model reports sigma < 0.1 px); the reported uncertainty (RMS over
// the grid) and the fraction of grid points within 3 sigma. Solves are deterministic, so the runs differ in
// time only.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <vector>

namespace curvecheck::experiments {

struct BenchCalibrateOptions {
  int runs = 3;                               // timed calibrations per lens model (median reported)
  int views = 30;                             // photos in the synthetic set
  uint64_t seed = 7;                          // seed of the set's poses and noise
  std::vector<int> splined_nx = {8, 12, 16};  // knot counts across of the splined models
  bool quick = false;  // recorded in the CSV's command line (the caller reduced views, knots)

  // Throws Error naming the option for runs outside 1..50 or views outside 6..200.
  void Check() const;
};

// Runs the bench, prints its table to `log`, and writes calibrate_bench.csv, calibrate_bench.png and its .gp
// into `dir`, an existing folder. A lens model whose calibration fails is reported and skipped.
void RunBenchCalibrate(const BenchCalibrateOptions& options, const std::filesystem::path& dir,
                       std::ostream& log);

}  // namespace curvecheck::experiments
