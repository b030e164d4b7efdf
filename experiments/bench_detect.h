// `curvecheck bench detect`: time and accuracy of every detector on synthetic photos of a scene (the default
// scene's 24 MP camera unless --scene says otherwise). For each pattern (the default 16x5 checkerboard, an
// 11x11 square board for mrgingham, the default AprilTag grid) it renders the pattern exact for the camera
// position, ray-traces one photo with the synthetic camera, then runs each applicable detector --runs times:
// median and min wall time of DetectFeatures (photo decoding excluded), and the error of the detected
// features against the synthetic truth (mean vector, RMS, max). Prints a table and writes detect_bench.csv
// and its chart.
#pragma once

#include <filesystem>
#include <ostream>
#include <string>

namespace curvecheck::experiments {

struct BenchDetectOptions {
  std::string scene = "default";  // scene file or embedded scene name (scene_lookup.h): its camera takes the photos
  int runs = 3;                                           // timed runs per detector (median reported)
  std::string patterns = "checkerboard,square,apriltag";  // which patterns to photograph
  bool uniform_display = false;  // display pixels uniform (fill factor 1, no RGB stripes), 4x4 supersampling

  // Throws Error naming the option for runs outside 1..100.
  void Check() const;
};

// Runs the bench, prints its table and the Pareto front to `log`, and writes detect_bench.csv,
// detect_bench.png and its .gp into `dir`, an existing folder. Throws Error for a bad scene file.
void RunBenchDetect(const BenchDetectOptions& options, const std::filesystem::path& dir, std::ostream& log);

}  // namespace curvecheck::experiments
