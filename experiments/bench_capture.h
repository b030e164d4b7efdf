// `curvecheck bench capture`: speed of the synthetic camera (RenderSyntheticPhoto) on one scene. The first
// photo builds the lens's ray table (mrcal unprojection) and is reported on its own; the timed runs reuse the
// table, as a sweep of photos through one lens does. Prints the median, min and max wall time, rays per
// second, and each stage's median wall and CPU time and share; CPU / wall shows how many cores the runs
// actually had on a machine shared with other work.
#pragma once

#include <ostream>
#include <string>

namespace curvecheck::experiments {

struct BenchCaptureOptions {
  std::string scene = "default";  // scene file, or the name of an embedded scene (scene_lookup.h)
  // Display image (PNG at the monitor's resolution); empty: the default checkerboard rendered for the camera.
  std::string display;
  int runs = 5;         // timed runs after the first (median reported)
  std::string output;   // CSV of every run; empty: none

  // Throws Error naming the option for runs outside 1..100.
  void Check() const;
};

// Runs the bench and prints its tables to `log` (and writes the CSV). Throws Error for a bad scene or display
// file.
void RunBenchCapture(const BenchCaptureOptions& options, std::ostream& log);

}  // namespace curvecheck::experiments
