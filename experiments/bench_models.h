// `curvecheck bench models`: speed against accuracy of the screen models (issue 7 item 2d).
//
// For each true screen (scenes default, radius-8pct, lean-1deg, bulge-2mm: a nominal 1000R panel that is a
// cylinder, a cylinder of another radius, a cylinder with its axis tilted, a cylinder with a 2 mm bump) and
// each seed, the true surface points of a 63 x 17 feature grid are projected through the scene's lens with
// Gaussian noise (noise_px per coordinate; no image, no detector: this isolates the model). Each model is
// then fitted ALONE (no selection, no held-out folds), and scored by:
//   - fit time (median over the seeds; one photo);
//   - radius error: RMS over the seeds of R_fit - R_true (models without a radius number: no entry);
//   - surface error: RMS over the features and seeds of the distance, in the camera frame, between the fitted
//     surface point (FittedSurfacePointsInCamera: model surface, deviation field included, placed by the
//     fitted camera pose) and the true surface point. The camera frame removes the gauge (the fitted centre
//     frame is arbitrary up to the pose), so this is the error of the shape the user would be shown, bulges
//     included.
// The whole selection (every model, 5 held-out folds) also runs once per scene, to show which model it picks.
#pragma once

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

namespace curvecheck::experiments {

struct BenchModelsOptions {
  // Scene names: files <name>.yaml in scenes_dir, or embedded scenes when scenes_dir is empty.
  std::vector<std::string> scenes = {"default", "radius-8pct", "lean-1deg", "bulge-2mm"};
  std::string scenes_dir;
  int seeds = 5;                       // noise seeds per case (times: median over them)
  int grid_cols = 63, grid_rows = 17;  // features across and down
  double noise_px = 0.1;               // detection noise, px per coordinate

  // Throws Error naming the option for seeds outside 1..1000, a grid side outside 4..400, noise outside
  // (0, 10) px, or no scene.
  void Check() const;
};

// Runs the bench and writes models_bench.csv and models_bench.png (+ .gp: two panels, time vs radius error
// and time vs surface error, log-log, one colour per scene, the Pareto front of each scene as a line) into
// `dir`, an existing folder; prints the table to `log`. Throws Error naming a scene that does not exist.
void RunBenchModels(const BenchModelsOptions& options, const std::filesystem::path& dir, std::ostream& log);

}  // namespace curvecheck::experiments
