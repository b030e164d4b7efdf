// `curvecheck bench calibrate --from-screen`: the calibration from the screen (calibrate/from_screen.h) over seeded
// trials of realistic synthetic photos (issue 20 part 2's acceptance benchmark).
//
// One display: the default pattern rendered for a viewpoint 1.5 m in front of the screen centre. Per trial (seed
// s): the scene's true radius is the nominal times a factor drawn from [1 - radius_spread, 1 + radius_spread]; 8 to
// 12 photos (drawn) from positions drawn in x in [-450, 450], y in [-120, 120], z in [400, 650] mm (screen frame,
// so 1.4-1.65 m from the screen centre), each looking at the screen centre with 1 deg of aim jitter, through the
// scene's realistic imaging chain at `scale` (sensor noise and lens misfit seeded per trial); the focal seed is
// the truth times (1 + 0.1 N(0, 1)); the panel's true pixel pitch is the datasheet's times 1 + d, d uniform in
// +-pitch_tolerance (the tolerance the calibration's budget states: its pixel-pitch row is exercised). Per trial: the lens against the truth (LensDifferencePx at 1.5 m: the median
// over the imager and over the grid points inside the detections' bounding box), whether the true radius lies in
// the reported 95% interval and within 2 sigma, and the time.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "calibrate/from_screen.h"
#include "experiments/trial.h"

namespace curvecheck::experiments {

struct BenchSelfCalibrateOptions {
  int trials = 20;
  uint64_t seed = 1;
  std::string scene = "default";  // an embedded scene name or a scene file
  double scale = 0.25;             // imager scale (quarter: 1500 x 1000 for the default camera)
  int min_photos = 8, max_photos = 12;
  double radius_spread = 0.05;     // relative, uniform
  double focal_seed_error = 0.1;   // relative sigma of the focal seed
  // Relative half-width of the true pitch's uniform draw: the screen fit's stated default (FitOptions), 0 for the
  // datasheet's pitch exactly.
  double pitch_tolerance = 0.001;
  // When the calibration's precision check fails (FromScreenResult::precise), add the suggested photos and
  // calibrate again, as a user told by the refusal would.
  bool follow_advice = true;
  void Check() const;              // throws Error naming the option
};

// One trial's outcome.
struct SelfCalibrationTrial {
  int photos = 0;
  std::string lensmodel, error;  // error: the calibration refused or failed (message)
  double lens_median_px = 0, lens_covered_median_px = 0, lens_covered_max_px = 0;
  // Over the grid cells that hold detections (CoveredCells), the rotation fitted there: |difference| median and
  // max, the calibration's own projection sigma (median), the largest Mahalanobis distance of the truth.
  double cells_median_px = 0, cells_max_px = 0, cells_median_sigma_px = 0, cells_max_mahalanobis = 0;
  // The first calibration (the drawn photos alone): its precision check, its error over the cells and its median
  // projection sigma there; `precise` of the final one (after the suggested photos, if any).
  bool first_precise = true, precise = true;
  double first_cells_median_px = 0, first_sigma_px = 0;
  double true_radius_mm = 0, radius_mm = 0, radius_sigma_mm = 0;
  bool in_ci95 = false, within_2sigma = false;
  double seconds = 0;
};

// Photographs `display` (its pattern.json text in `pattern`) from `positions_in_screen` (mm, each looking at the
// screen centre, aim jitter in deg) with `scene` (camera already scaled), seeds the focal length with
// focal_seed_px, calibrates from the screen (the precision check reported, not refused) and, if the check fails and
// follow_advice, photographs the suggested positions too and calibrates again; compares with the scene's camera and
// true radius.
SelfCalibrationTrial RunSelfCalibrationTrial(const SyntheticScene& scene, const TrialDisplay& display,
                                             const PatternFile& pattern,
                                             const std::vector<Eigen::Vector3d>& positions_in_screen,
                                             double aim_jitter_deg, uint64_t seed, double focal_seed_px,
                                             const FromScreenOptions& options = {}, bool follow_advice = true);

// Runs the bench, prints a row per trial and the summary (lens error, coverage with Wilson 95% intervals) to
// `log`, and writes self_calibrate_trials.csv into `dir` (an existing folder).
void RunBenchSelfCalibrate(const BenchSelfCalibrateOptions& options, const std::filesystem::path& dir,
                           std::ostream& log);

}  // namespace curvecheck::experiments
