// `curvecheck bench calibrate --flat-vs-board`: the calibration from a FLAT monitor (calibrate --from-screen) against
// a board calibration (calibrate.h, mrcal) of the same synthetic camera (issue 20 part 2: "on a flat monitor, it
// agrees with a board calibration of the same camera within the two calibrations' uncertainties").
//
// One camera per trial: the scene's (default: the 24 MP OPENCV8 camera at `scale`), photographed through the scene's
// realistic imaging chain with one lens (its lens misfit field fixed by the trial's lens_seed) in both sets:
//   (i)  photos_min..photos_max photos of the flat monitor (`monitor`, default the 27" 2560 x 1440 flat preset)
//        showing the default pattern, from positions drawn in x in [-max_x, max_x], y in [-max_y, max_y],
//        z in [z_min, z_max] mm (screen frame: origin at the screen centre, +z toward the viewer), each looking at
//        the screen centre moved by up to +-15% of the screen's width and height (so that the screen lands on
//        different parts of the image) with 1 deg of aim jitter; a position is redrawn until the whole screen is
//        inside the image with a 2% margin. calibrate --from-screen (auto lens model) with the focal length seeded
//        10% off.
//   (ii) a synthetic board set (synth/synthetic_board.h: 24 views, 10 x 7 corners, the board pushed toward every
//        region of the imager, tilts up to 45 deg) through the same imaging chain, calibrated by mrcal with
//        LENSMODEL_OPENCV5 (OPENCV8, the truth's model, lets its rational pairs cancel: mrcal ran away to
//        distortions of 1e4 on this set), without cross-validation.
// Comparison (calibrate/projection_compare.h): mrcal's projection difference on a 30 x 20 grid of cell centres,
// the rotation between the two camera frames fitted over, and the statistics taken on, the cells that hold
// detections in both sets (the area both calibrations saw), against the combined uncertainty of both (each
// calibration's intrinsics covariance propagated through the difference). Decision rule per trial: the two agree
// when the largest per-cell Mahalanobis distance m = sqrt(d^T Cov^-1 d) is at most sqrt(chi2_2 quantile at
// 0.05 / r), r the rank of the combined covariance over the region (its independent error modes: a Bonferroni
// bound over them, 95% family-wise). Each calibration is also compared with the true lens (same grid and region):
// the camera model plus its misfit field (synth/lens_misfit.h), the lens both sets were photographed through.
//
// Each calibration's stated covariance is compared: the from-screen one as calibrate --from-screen states it (the
// sum of its intrinsics budget's rows: FromScreenIntrinsicsBudget), the board's as mrcal's (detection noise) plus
// the share of its misfit measured from its residuals (CandidateResult::intrinsics_covariance_misfit); each with the
// misfit field it measured as the lens's unmodelled departure when compared with the truth
// (LensWithCovariance::unmodelled). For the record, both detection-noise covariances alone (what was stated
// before the budgets; the "noise" columns). Diagnostics per
// trial: the detectors' errors against the true image positions (RMS, mean, and the RMS of their smooth part: a
// Legendre field of degree 3 fitted to them), for the screen's features and the board's corners; where the largest
// Mahalanobis distance of each comparison lies.
//
// The observations (screen features and board corners with their true positions) are cached in
// DIR/cache/seed-N.json and read back when present: the rendering and detection (most of a trial's time) are done
// once per seed; delete the folder to render again.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include <Eigen/Core>

#include "calibrate/projection_compare.h"
#include "experiments/detection_errors.h"

namespace curvecheck::experiments {

struct BenchFlatVsBoardOptions {
  int trials = 6;
  uint64_t seed = 1;
  std::string scene = "default";
  std::string monitor = "27in-2560x1440-flat";
  double scale = 0.25;
  int min_photos = 8, max_photos = 12;
  double max_x_mm = 400, max_y_mm = 250, z_min_mm = 600, z_max_mm = 900;
  int board_views = 24;
  void Check() const;  // throws Error naming the option
};

struct FlatVsBoardTrial {
  int photos = 0;
  std::string screen_lensmodel, board_lensmodel, error;  // error: refused or failed (message)
  int cells = 0;  // grid cells compared
  // With the screen calibration's stated covariance (its budget), and with its noise row alone.
  ProjectionComparison screen_vs_board, screen_vs_truth, board_vs_truth;
  // Both calibrations' detection-noise covariances alone (as stated before the budgets): screen vs board, each vs
  // the truth.
  ProjectionComparison screen_vs_board_noise, screen_vs_truth_noise, board_vs_truth_noise;
  double threshold_mahalanobis = 0, threshold_noise = 0;
  bool agree = false, agree_noise = false;
  double fx_screen = 0, fx_screen_sigma = 0, fx_screen_sigma_noise = 0, fx_board = 0, fx_board_sigma = 0;
  std::string screen_budget_note;  // non-empty: the budget could not be computed (why)
  double screen_unmodelled_px = 0;  // the misfit RMS the screen fit measured (px per coordinate)
  double true_misfit_px = 0;        // the synthetic lens's misfit RMS (px per coordinate)
  double board_misfit_px = 0;       // the misfit RMS the board calibration measured (mrcal_solve.py misfit_field)
  DetectionErrors screen_detection, board_detection;
  std::string screen_summary;  // FromScreenSummary of the calibration from the screen, and the board's misfit
  bool from_cache = false;
  double seconds = 0;
};

// One trial (seed: positions, noise, lens misfit field, board poses). cache_dir: where the observations are cached
// (empty: none).
FlatVsBoardTrial RunFlatVsBoardTrial(const BenchFlatVsBoardOptions& options, uint64_t seed,
                                     const std::filesystem::path& cache_dir = {});

// Runs the bench, prints a row per trial and the summary (agreement with its Wilson 95% interval) to `log`, and
// writes flat_vs_board_trials.csv and, per trial, trial-K.txt (the screen calibration's summary with its
// uncertainty rows, the board's measured misfit) into `dir` (an existing folder).
void RunBenchFlatVsBoard(const BenchFlatVsBoardOptions& options, const std::filesystem::path& dir, std::ostream& log);

}  // namespace curvecheck::experiments
