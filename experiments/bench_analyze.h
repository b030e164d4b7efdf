// `curvecheck bench analyze`: the accuracy and speed of the whole analysis on synthetic truth (issue 6 items
// 7 and 8). One corrected checkerboard is rendered for the scene's camera position; then, for each seed, the
// synthetic camera takes a new photo (only the sensor noise differs) and the photo is analysed from pixels:
// detection, verification, the screen fit of every model (the trial of trial.h). Reported: the `cylinder`
// candidate's radius against the truth (bias in mm and in sigmas, the empirical sigma against the mean
// reported sigma and the Cramer-Rao bound at the truth, the coverage of the 95% intervals), the model chosen,
// and the median time of each stage.
//
// The seeds share everything but the noise: the renderer's anti-aliasing and the detector's systematic errors
// are the same in every photo, so a bias they cause shows as bias here, which is what a user would meet.
#pragma once

#include <filesystem>
#include <ostream>
#include <string>

namespace curvecheck::experiments {

struct BenchAnalyzeOptions {
  std::string scene = "default";  // scene file, or the name of an embedded scene (scene_lookup.h)
  int seeds = 20;                 // photos (noise seeds 1..seeds); at least 2 for a spread
  int cols = 32, rows = 9;        // checkerboard squares

  // Throws Error naming the option for fewer than 2 seeds, or cols or rows outside 2..1000.
  void Check() const;
};

// Runs the bench into `out` (an existing folder: pattern.json, analyze_bench.csv, analyze_bench.txt),
// printing a row per seed and the summary to `log`. Returns true when at least 2 seeds gave a radius (the
// statistics exist). Throws Error for an unknown scene.
bool RunBenchAnalyze(const BenchAnalyzeOptions& options, const std::filesystem::path& out, std::ostream& log);

}  // namespace curvecheck::experiments
