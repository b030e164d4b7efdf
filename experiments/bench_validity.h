// `curvecheck bench validity` (issue 16 item 4): is the reported radius interval honest under imaging
// conditions the project was not tuned on? Seeded trials of the whole chain over a grid of conditions; per
// cell the bias in sigmas, the scatter against the reported sigma and the coverage of the 68% and 95%
// intervals (validity_stats.h), for the radius and for the camera position.
//
// Grid (canonical order, outermost first): resolution scale of the scene's camera (ScaledCamera) x camera
// distance from the screen centre x yaw (the camera moved horizontally around the screen centre, looking at
// it; positive to the right) x realism (the imaging chain: `off` imaging.preset=clean, `on` imaging.preset=ilc24, as
// scene overrides: RealismOverrides) x true radius factor (the true monitor's radius = factor x the
// nominal's; the pattern is always rendered for the nominal monitor, as a user would) x trials. Trial k of
// the grid (in this order) uses noise seed `seed` + k and a camera pose jitter drawn from a generator seeded
// with it: the position moved by N(0, jitter_mm) per axis, the aim turned by a rotation vector with N(0,
// jitter_deg) per axis, so that the features' subpixel phases differ between trials as between real photos
// (without it every trial of a cell would photograph the same phases and a detector's systematic error would
// look like bias, not scatter). The pattern is rendered for the jittered camera position (exact method),
// photographed by the synthetic camera and analysed from pixels with the default analysis (every screen
// model; the chosen one's numbers are used, as a user sees).
//
// Truth (never from the analysis): the radius 1 / scene.truth.curvature_per_mm; the camera position in the
// true screen's centre frame (the true monitor's translation and rigid rotation removed; a lean is not
// modelled here) and in its axis frame (centre frame shifted by -R_true in z), against the chosen fit's
// CameraEstimate in the same frames with their sigmas. Radius: the 68% and 95% intervals radius_ci68_mm and
// radius_ci95_mm (as the fit reports them); camera coordinates: +- k68 sigma and +- k95 sigma, the budget's
// coverage factors for that coordinate (columns cam_FRAME_AXIS_k68, _k95; 1 and 1.96 when absent). Coverage rates
// carry Wilson 95% intervals.
//
// Shards (shards.h): trials k with k mod n = i - 1; validity_trials.csv has one row per trial, and every cell
// statistic is computed from those rows, so `bench validity merge` of all shards reproduces an unsharded run.
// Outputs in the output folder: validity_trials.csv, validity.csv (one row per cell), validity.json,
// validity.txt (the table and the acceptance summary: ValidityRule), validity.png (+ .gp, .dat: the 95%
// coverage per cell with its Wilson interval and the 90-98% band; bias in sigmas per cell with its standard
// error and the +-0.5 band).
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/screen_fit.h"
#include "experiments/shards.h"

namespace curvecheck::experiments {

struct BenchValidityOptions {
  std::vector<double> scales = {0.25, 0.5, 1.0};           // of the scene camera's imager, (0, 1]
  std::vector<double> distances_mm = {1000, 2000, 3000};   // camera to screen centre, 300..20000
  std::vector<double> yaws_deg = {0, 20, 40};              // around the screen centre, |yaw| < 80
  std::vector<std::string> realism = {"off", "on"};        // imaging chain levels (RealismOverrides)
  std::vector<double> radius_factors = {0.92, 1.0, 1.08};  // true radius / nominal, 0.5..2
  int trials = 20;                                         // per cell, 1..10000
  int64_t seed = 1;                                        // trial k uses seed + k
  std::string scene = "default";  // its monitor, lens, optics, sensor; the bench places the camera
  double jitter_mm = 3;           // camera position jitter, per axis (1 sigma), mm
  double jitter_deg = 0.2;        // camera aim jitter, per axis (1 sigma), deg
  // The true panel's pixel pitch is the datasheet's times 1 + d, d drawn per trial uniformly in +-this, and the
  // analysis is told this tolerance (FitOptions::pitch_tolerance_relative, as analyze --pitch-tolerance), so that
  // its budget row is tested like the others. 0: the datasheet's pitch exactly and no pitch row, so that the
  // other rows are tested alone (with the default 0.1% the pitch row is 0.58 mm of a 1000 mm radius, often the
  // largest, and can hide that the others are too small).
  double pitch_tolerance_percent = 0.1;  // as analyze --pitch-tolerance
  // The analysis is told the true lens's misfit (its RMS at the trial's imager times this factor, and its
  // correlation length) as the calibration's measurement (FitOptions::stated_lens_misfit_px: curvecheck calibrate
  // writes it beside the camera model). 1: a calibration that measured it exactly; 0: not told, the
  // lens-model-misfit row from the photo's residuals alone. The bench does not calibrate: a real calibration's
  // estimate scatters (docs/bench/flat_vs_board.txt: 0.6-3x the true RMS), so run 0.5 and 2 to see what that does.
  double lens_misfit_stated = 1;
  bool correct_pixel_locking = false;  // AnalyzeOptions::correct_pixel_locking (analyze --correct-pixel-locking)
  // The analysis's prior on each pixel-locking coefficient, px (FitOptions::pixel_locking_prior_px, analyze
  // --pixel-locking-prior; 0: none): an ablation of the prior.
  double pixel_locking_prior_px = FitOptions{}.pixel_locking_prior_px;
  // Also measure what the detector's systematic error did to the radius: each trial's display photographed again
  // without sensor noise, its detections' errors against the truth (the detector's deterministic error there)
  // taken from the trial's observations, and the fit repeated (validity_trials.csv sys_shift_mm beside the budget's
  // row 2 parts smooth_share_mm and locking_share_mm). A second photo and two more fits per trial.
  bool detector_effect = false;
  // Keep every trial's result.json (OUT/results/trial-INDEX.result.json): every candidate's fit, budget and choice,
  // to see why a trial missed.
  bool keep_results = false;
  int cols = 32, rows = 9;        // checkerboard squares
  // The pattern shown: "checkerboard" (cols x rows squares) or "apriltag" (tag_cols x tag_rows tag36h11 tags, the
  // tags' size fitted to the screen): the detection-noise row counts a tag's four corners as independent though
  // they share the tag's own error, which only a tag bench tests.
  std::string pattern = "checkerboard";
  int tag_cols = 16, tag_rows = 4;
  Shard shard;
  std::string command_line;  // provenance

  // Throws Error naming the option for an empty list or a value out of range, an unknown realism level, a
  // negative seed or jitter, or a bad shard.
  void Check() const;
};

// The scene overrides ("key=value", synth/scene.h LoadScene) of a realism level: "off" and "on", each optionally
// followed by more overrides after '+' ("on+imaging.cfa=none": the realistic chain without its colour filter
// array, an ablation of one effect). Throws Error naming --realism for anything else.
std::vector<std::string> RealismOverrides(const std::string& level);

// What a validity bench's shard folder holds (validity.json, validity_trials.csv).
const ShardFiles& ValidityShardFiles();

// Runs this shard of the bench, printing a line per trial and the table to `log`, and writes the outputs into
// `out` (an existing writable folder; scratch files in out/.validity-scratch-<i>, removed). Returns true when
// every cell with trials meets ValidityRule (the exit code does not depend on it: a failing cell is a
// result). Throws Error for an unknown scene or invalid options.
bool RunBenchValidity(const BenchValidityOptions& options, const std::filesystem::path& out,
                      std::ostream& log);

// Merges the shards in `dirs` (ShardDirs with ValidityShardFiles) into `out`: the same outputs as an
// unsharded run. Returns as RunBenchValidity. Throws Error naming the file for shards of different grids or
// overlapping ones.
bool MergeBenchValidity(const std::vector<std::filesystem::path>& dirs, const std::filesystem::path& out,
                        const std::string& command_line, std::ostream& log);

}  // namespace curvecheck::experiments
