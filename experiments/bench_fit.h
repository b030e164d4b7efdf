// `curvecheck bench fit`: the screen fit on synthetic truth (analysis/screen_fit.h). Observations are the
// true surface points of a scene projected through its lens plus seeded Gaussian noise (no image, no
// detector: this measures the fit alone).
//   1. Speed: median over --runs of FitScreen with one model at a time (no held-out folds), for one photo of
//      31 x 9 features and for ten photos of 42 x 12 features from ten camera positions; then the whole
//      selection (every model, 5 folds) on the one photo.
//   2. Accuracy: --seeds single-photo fits of the cylinder: radius bias, scatter against the Cramer-Rao bound
//      of the same configuration, mean reported sigma, coverage of the 95% interval.
#pragma once

#include <ostream>
#include <string>

namespace curvecheck::experiments {

struct BenchFitOptions {
  std::string scene = "default";  // scene file or embedded scene name (scene_lookup.h): its true monitor, camera
  int runs = 5;                                        // timed runs per case (median reported)
  int seeds = 1000;                                    // seeded single-photo fits for the radius statistics
  double noise_px = 0.1;                               // detection noise, px per coordinate
};

// Runs the bench and prints its tables to `log`. Throws Error for a bad scene file.
void RunBenchFit(const BenchFitOptions& options, std::ostream& log);

}  // namespace curvecheck::experiments
