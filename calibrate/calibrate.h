// Camera calibration from chessboard detections: mrcal solves, the rig chooses the lens model.
//
// How (argued): the detections come from detect/chessboard.h; the focal length is seeded by OpenCV
// (initCameraMatrix2D, from the boards' homographies); each candidate lens model is then seeded and solved by
// mrcal's Python API (mrcal_solve.py, embedded, run with /usr/bin/python3), because in mrcal 2.2 the seeding and
// the projection uncertainty exist only there: the same calls mrcal-calibrate-cameras makes, with mrcal's outlier
// rejection and regularization. The written model keeps mrcal's optimization inputs, so mrcal's own tools
// (mrcal-show-projection-uncertainty, mrcal-show-residuals, ...) work on it.
//
// Model choice (issue 5 item 2): candidates from the simplest (fewest parameters) up; the first that is
// adequate is chosen, where adequate means
//   - no structure in the residuals: the per-cell mean residual over the imager is consistent with noise
//     (z of a chi-square test below `structure_z_max`; see mrcal_solve.py structure()), and
//   - cross-validation passes: the photos are split into two halves (even / odd), each calibrated alone; their
//     projection difference (mrcal.projection_diff, implied rotation fitted) over the observed region is
//     compared with the uncertainty both halves predict, sqrt(s_a^2 + s_b^2); the median ratio must stay below
//     `crossval_ratio_max` (mrcal's cross-validation: a model that fits has differences the size of its noise).
// If none is adequate, the candidate with the best cross-validation ratio is chosen and the result says so.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibrate/photos.h"
#include "pattern/board.h"
#include "detect/chessboard.h"
#include "core/camera_model.h"
#include "core/image_hash.h"

namespace curvecheck {

struct CalibrateOptions {
  // Lens models to try, simplest first. Empty = auto: LENSMODEL_OPENCV4, LENSMODEL_OPENCV8 and
  // LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=<splined_nx>_Ny=<by aspect>_fov_x_deg=auto (the field of view
  // from the stereographic seed, plus 10%). One model = no choice, but still measured and cross-validated.
  std::vector<std::string> lensmodels;
  int splined_nx = 16;               // spline knots across; mrcal's guide uses ~30 for dense 24 MP sets
  double focal_px = 0;               // seed; 0 = from OpenCV's initCameraMatrix2D on the detections
  bool cross_validate = true;        // needs >= 2 * min_photos_per_half photos with a board
  int min_photos_per_half = 5;
  double structure_z_max = 4;        // residual-structure test threshold (standard normal units)
  double crossval_ratio_max = 1.5;   // median of |diff| / sqrt(s_a^2 + s_b^2) over the observed region
  // Where uncertainty and differences are evaluated: points at this distance along each pixel's ray; 0 = at
  // infinity. The rig looks at a monitor ~0.5-2 m away; mrcal's uncertainty grows toward both ends.
  double distance_mm = 1000;
  int grid_x = 16, grid_y = 12;      // evaluation grid over the imager (cell centres)
  int structure_x = 8, structure_y = 6;  // cells of the residual-structure test
  uint64_t seed = 1;                 // of mrcal's tiny random seed for the distortions (reproducible runs)
  std::string python = "/usr/bin/python3";  // Debian's interpreter with python3-mrcal
  void Check() const;
};

struct UncertaintyGrid {
  std::vector<Eigen::Vector2d> pixel_px;  // cell centres
  std::vector<double> sigma_px;           // worst-direction standard deviation of projection (mrcal)
  std::vector<bool> observed;             // within reach of observed corners (where the data is)
};

struct CandidateResult {
  std::string lensmodel;
  std::string error;  // non-empty: the solve failed (the message from mrcal)
  int nparams = 0;
  double rms_px = 0, worst_px = 0;  // residual vector length over inliers
  int ninliers = 0, noutliers = 0;
  double solve_s = 0;
  double structure_z = 0, structure_chi2_per_dof = 0;
  int structure_cells = 0;
  bool crossval_done = false;
  double crossval_rms_diff_px = 0, crossval_rms_expected_px = 0, crossval_ratio_median = 0, crossval_ratio_p90 = 0;
  double crossval_s = 0;
  bool no_structure = false, crossval_pass = false;
  std::vector<double> intrinsics;
  // Per used photo, the board's pose in the camera frame (mrcal's rt: Rodrigues rotation, translation in mm),
  // for the board corners in the order detected (BoardSpec::CornersInBoard()).
  std::vector<Eigen::Matrix<double, 6, 1>> cam_from_board_rt;
  UncertaintyGrid uncertainty;
  std::vector<double> per_photo_rms_px;                   // per used photo
  std::vector<std::vector<Eigen::Vector2d>> residuals_px;  // per used photo, per corner (row-major)
  std::vector<std::vector<bool>> inlier;                   // false: rejected as an outlier
  std::string model_text;  // the .cameramodel file mrcal wrote, with its optimization inputs
  // The covariance of the intrinsics (mrcal's order and units), marginal over the board poses: the observed pixel
  // noise s squared times the intrinsics block of inv(J^T J) in mrcal's unpacked state (mrcal_solve.py
  // intrinsics_covariance); dof = 2 x inlier corners - states. Empty when mrcal could not factor J^T J.
  Eigen::MatrixXd intrinsics_covariance;
  double intrinsics_covariance_dof = 0, observed_pixel_uncertainty_px = 0;
  // The lens-model misfit measured from the residuals' correlation between photos (mrcal_solve.py misfit_field): a
  // stationary Gaussian field over the image, common to every photo, of variance misfit_variance_px2 per coordinate
  // and length misfit_length_px, and its share of the intrinsics' covariance (the part of the field the intrinsics
  // absorb, propagated through the solve's linearization). Not in intrinsics_covariance (mrcal's noise-only one,
  // which the sidecar holds); a comparison of two calibrations adds it (bench calibrate --flat-vs-board). Empty when
  // not measured (misfit_note says why).
  Eigen::MatrixXd intrinsics_covariance_misfit;
  double misfit_variance_px2 = 0, misfit_length_px = 0;
  std::string misfit_note;

  bool adequate() const { return error.empty() && no_structure && (!crossval_done || crossval_pass); }
  // Uncertainty summaries (px): median over the central half of the imager (where a monitor is framed),
  // median and max over the observed region.
  double SigmaCentralMedian(int width, int height) const;
  double SigmaObservedMedian() const;
  double SigmaObservedMax() const;
};

// The sidecar written beside a calibrated camera model, CAM.intrinsics_covariance.json, that `curvecheck analyze`
// propagates into its uncertainty budget (analysis/screen_fit.h ReadIntrinsicsCovariance):
//   { "format": "curvecheck.intrinsics_covariance/1", "model": CAM file name, "lensmodel": .., "intrinsics": [..],
//     "covariance": n x n (mrcal's intrinsics order; px^2 for fx fy cx cy, the distortions' units squared),
//     "dof": residual degrees of freedom, "observed_pixel_uncertainty_px": s, "method": .. }
// Throws Error when the candidate has no covariance.
nlohmann::json IntrinsicsCovarianceJson(const CandidateResult& c, const std::string& model_file);

struct CalibrationResult {
  BoardSpec board;
  int width = 0, height = 0;
  std::vector<ChessboardDetection> detections;  // all photos, in input order
  // Per photo, when gathered by DetectCalibrationPhotos (else empty): the decoded content's hash, and -1 or the
  // index of the earlier photo with the same content. A duplicate is not used: each content counts once.
  std::vector<std::optional<ContentHash>> content;
  std::vector<int> duplicate_of;
  std::vector<std::string> notes;     // one line each: the duplicates (CalibrationPhotos::DuplicateNotes)
  std::vector<int> used;              // indices into detections of the photos with a board (duplicates left out)
  double focal_seed_px = 0;
  std::vector<CandidateResult> candidates;
  int chosen = -1;
  std::string choice;  // why this candidate
  CameraModel model;   // the chosen one
  double optimize_s = 0;  // wall time of all solves (including the Python start)

  const CandidateResult& Chosen() const { return candidates.at(static_cast<size_t>(chosen)); }
};

// Calibrates from detections (all of one camera, one imager size). Throws Error if too few photos hold a board
// (fewer than 3), if the sizes differ, or if mrcal cannot be run; a candidate that fails to solve is reported in
// its row, not thrown.
CalibrationResult Calibrate(const std::vector<ChessboardDetection>& detections, const BoardSpec& board,
                            const CalibrateOptions& options);
// The same for photos gathered by DetectCalibrationPhotos: a photo whose decoded content repeats an earlier one's
// is left out (each content counts once, the first photo holds it), and the result's `notes` say so, naming both.
// Calibrating a set plus duplicates therefore gives exactly the set's result.
CalibrationResult Calibrate(const CalibrationPhotos& photos, const BoardSpec& board, const CalibrateOptions& options);

// The candidate table (one row per model) and the choice, as printed by `curvecheck calibrate`.
std::string CandidateTable(const CalibrationResult& r);

// The calibration report (format curvecheck.calibration/1): board, detections (per photo: found, detector,
// time, decoded content hash, `duplicate_of` for a duplicate), the notes (duplicates), every candidate's figures, the choice, the chosen model's per-photo RMS, per-corner residuals and
// outlier flags, and its uncertainty grid.
nlohmann::json CalibrationJson(const CalibrationResult& r);

// The embedded solver script (for tests and for running it by hand).
const std::string& MrcalSolveScript();

}  // namespace curvecheck
