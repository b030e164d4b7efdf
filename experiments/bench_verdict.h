// `curvecheck bench verdict`: how often the verification's three-state verdict (analysis/verify.h: pass when
// e + U <= T, fail when e - U > T, otherwise inconclusive) is right, on seeded synthetic trials whose truth is
// known (issue 15, "Tests and benchmark").
//
// Grid: camera distances (from the screen centre, looking at it) x views (on the screen's axis; off axis: moved
// around the screen centre by off_axis_yaw_deg to the right and off_axis_pitch_deg up, as the off-axis scene) x
// cases x resolution scales of the scene's camera (ScaledCamera) x trials. Cases, each an exact rendering:
//   correct  rendered for the camera's position on the nominal monitor, which is the true one: pattern.json
//            states where the camera is. Truth: correct (its true error is 0).
//   offset   rendered for a viewpoint offset_mm from the camera, across its line of sight (trial t: direction
//            t x 90 deg from the camera's right, counter-clockwise as the camera sees it: right, up, left, down).
//            pattern.json states the rendering's viewpoint, as `render` writes it: the rendering is what
//            pattern.json says, but the camera is not where pattern.json says it is. That is the user's mistake
//            this case stands for (the camera put 25 mm from the stated viewpoint).
//   radius   rendered for the camera's position on the nominal monitor (the scene's, 1000R by default), while
//            the true monitor has radius wrong_radius_mm (SyntheticScene::truth, as the radius scenes set it).
// Every trial photographs with its own noise seed (seed + its index in the grid's canonical order: distance,
// view, case, scale, trial), detects and verifies (no screen fit). The truth of a trial is its true correction
// error (true_correction_error.h: from the synthetic camera's geometry, not the analysis): a perturbed trial is
// "wrong" when that error exceeds the tolerance T; a perturbation too small to exceed T (possible far away) is
// counted apart, as "within tolerance", since a pass is then right.
//
// Output: the confusion matrix (truth x verdict pass / fail / inconclusive / none), the false-fail rate on
// correct corrections and the false-pass rate on wrong ones, each with its Wilson 95% interval, per scale and
// distance and overall; how often e +- U holds the true error (the coverage of the expanded uncertainty); the machine and the command; verdict_bench.csv (one row per trial), verdict_bench.json
// (options, counts and rates, the trials) and verdict_bench.txt (the summary) in the output folder.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

namespace curvecheck::experiments {

struct BenchVerdictOptions {
  std::vector<double> scales = {0.25, 0.5, 0.75, 1.0};         // of the scene camera's imager, (0, 1]
  std::vector<double> distances_mm = {1000, 2000, 3000};      // camera to screen centre
  std::vector<std::string> views = {"on-axis", "off-axis"};   // which views
  int trials = 3;  // per cell (distance, view, case, scale)
  int64_t seed = 1;
  std::string scene = "default";  // the monitor, camera, optics and sensor (scene_lookup.h)
  double off_axis_yaw_deg = 15, off_axis_pitch_deg = 5;
  double offset_mm = 25;          // the offset case's misstated viewpoint
  double wrong_radius_mm = 1080;  // the radius case's true radius
  double tolerance_display_px = 0.5;
  int cols = 32, rows = 9;        // checkerboard squares (the sweep's board)
  std::string command_line;       // provenance

  // Throws Error naming the option: scales outside (0, 1], distances outside 300..20000 mm, an unknown view,
  // trials outside 1..10000, a negative seed, a non-positive offset, radius or tolerance.
  void Check() const;
};

// Runs the bench, printing a line per trial and the summary to `log`, and writes verdict_bench.csv, .json and
// .txt into `out` (an existing folder; scratch pattern.json files go to out/.verdict-scratch and are removed).
// Throws Error for an unknown scene or invalid options.
void RunBenchVerdict(const BenchVerdictOptions& options, const std::filesystem::path& out, std::ostream& log);

}  // namespace curvecheck::experiments
