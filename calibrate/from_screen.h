// Camera calibration from photos of the monitor itself (issue 20 part 2): no printed board. The lens intrinsics
// are estimated jointly with every photo's camera pose and the screen's curvature by the screen fit
// (analysis/screen_fit.h with FitOptions::fit_intrinsics: Ceres, the mrcal lens model projected through libmrcal
// with its exact gradients dq/dX and dq/dintrinsics), seeded from a focal length (EXIF or stated).
//
// Observability (argued; the figures of a run are in FromScreenObservability):
//   - Scale: the photos alone cannot tell a larger, farther screen from a smaller, nearer one. The monitor preset's
//     pixel pitch (the screen's physical size) fixes it: the screen fit keeps the pitch fixed.
//   - Focal length against distance: a screen seen square-on and small in the image measures only f / d (its image
//     width is about f W / d). What separates them is perspective: the screen's depth (a 1000R 49" panel is
//     ~170 mm deep at its ends) and views from different yaws and distances, whose foreshortening depends on d
//     but not on f. With too small a spread of viewing directions the coupling is nearly exact: the fit's
//     correlation of fx with the camera distance then approaches 1 and the photos are refused, with what to add.
//   - Principal point against rotation: a shift of (cx, cy) is nearly a small rotation of every camera; the poses
//     absorb it, so cx, cy carry larger sigmas than fx, fy, and the lens comparison with a truth fits the implied
//     rotation (mrcal's projection_diff does the same).
//   - Distortion: constrained only where the photos put features (the screen's band in the image); beyond it the
//     model extrapolates. The simplest adequate lens model is chosen (BIC; see FromScreenOptions).
// The radius's sigma comes from the joint covariance (marginal over the intrinsics and the poses) plus the
// screen fit's systematic rows propagated through the joint linearization: it includes the lens's uncertainty.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/screen_fit.h"
#include "core/camera_model.h"
#include "core/monitor.h"
#include "detect/detect.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

struct FromScreenOptions {
  // Lens models to try, simplest first (fewest parameters). Empty = auto: LENSMODEL_OPENCV4, LENSMODEL_OPENCV5,
  // LENSMODEL_OPENCV8. Splined models are not offered: the screen covers a band of the image, far too little to
  // constrain hundreds of knots.
  std::vector<std::string> lensmodels;
  // A richer lens model is chosen only if its BIC (of the screen fit's residuals) is lower than every simpler
  // one's by more than bic_margin (10: "very strong" on Kass and Raftery's scale), as the screen fit chooses shapes.
  double bic_margin = 10;
  // Focal length seed, px (from EXIF or --focal-px). 0: none; then OPENCV4 is fitted from trial seeds of 0.6, 0.85,
  // 1.2 and 1.7 times the image diagonal and the fitted focal length of the lowest residual seeds the candidates.
  double focal_px = 0;
  // Refusals (too few or too similar photos). Each photo adds 6 pose parameters; the lens adds 8-12 and the
  // screen 1, so fewer than min_photos leaves too few constraints per parameter.
  int min_photos = 6;
  // Spread of the viewing directions: the largest angle between two photos' directions from the screen centre to
  // the camera. Below this the focal length cannot be told from the distance (see the header).
  double min_view_spread_deg = 10;
  // After the fit: refused when |corr(fx, distance)| of every photo exceeds this (the coupling is not broken) or
  // the relative sigma of fx exceeds max_relative_focal_sigma.
  double max_focal_distance_correlation = 0.999;
  double max_relative_focal_sigma = 0.01;
  // Precision where the photos put features (FromScreenProjection): the calibration's own projection sigma
  // (worst direction, the rotation a principal point trades with absorbed; from the stated covariance, every row of
  // the intrinsics budget) over the grid cells that hold detections. Its median must not exceed
  // max_projection_sigma_px: 0.3 px / sqrt(chi2_2(0.95)) = 0.3 / 2.45, so that the lens is within 0.3 px at 95%
  // there (issue 20's requirement). 0: no limit. One behaviour, the CLI's (calibrate_run.h): by default
  // (refuse_imprecise false) a shortfall is reported, not refused: `precise` is false and `suggested` holds the
  // positions to add, and the calibration is still returned with its uncertainty; with refuse_imprecise (the CLI's
  // --max-projection-sigma S sets it, with S as the limit) the photos are refused (Error) with those positions.
  double max_projection_sigma_px = 0.3 / 2.4477;
  bool refuse_imprecise = false;
  // The screen fit's options; models and fit_intrinsics are set by CalibrateFromScreen (the cylinder for a
  // curved monitor, flat for a flat one; held-out folds off: the choice among shapes is not the question here).
  FitOptions fit;
  void Check() const;  // throws Error naming the option
};

// What the photos make observable, from the chosen candidate's joint covariance.
struct FromScreenObservability {
  std::vector<std::string> names;         // fx, fy, cx, cy, then the distortions (mrcal's names where known)
  std::vector<double> sigma;              // per intrinsic (its unit), detection-noise covariance
  Eigen::MatrixXd correlation;            // of the intrinsics
  double correlation_condition = 0;       // condition number of that correlation matrix (1 = independent)
  std::vector<double> focal_distance_correlation;  // per photo: corr(fx, |camera - screen centre|)
  double max_abs_focal_distance_correlation = 0;
  double curvature_focal_correlation = 0;  // corr(k, fx)
  double view_spread_deg = 0;              // largest angle between two photos' viewing directions
  double distance_min_mm = 0, distance_max_mm = 0;
  std::string statement;  // one paragraph for people (printed and in the JSON)
};

// The calibration's projection uncertainty over the imager: a grid_x x grid_y grid of cell centres; per cell the
// worst-direction sigma of the chosen lens's projection (its intrinsics covariance propagated through mrcal's
// projection difference with the rotation fitted over the covered cells: calibrate/projection_compare.h), and
// whether the cell holds detections (covered). The calibration is valid (its lens known to the stated precision)
// on the covered cells whose sigma is at most the limit; elsewhere the distortion is extrapolated.
struct FromScreenProjection {
  int grid_x = 30, grid_y = 20;
  std::vector<Eigen::Vector2d> pixel_px;  // row-major
  std::vector<double> sigma_px;
  std::vector<bool> covered, valid;
  int covered_cells = 0, valid_cells = 0;
  double covered_median_sigma_px = 0, covered_max_sigma_px = 0, limit_px = 0;
};

// A camera position to add (screen frame, mm), aimed at look_at_mm, and why.
struct SuggestedPosition {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero(), look_at_mm = Eigen::Vector3d::Zero();
  std::string why;
};

// The intrinsics' uncertainty, one row per source (metrology.md section 1), of the chosen candidate
// (IntrinsicsBudgetFromScreen): the detection noise (the joint fit's covariance), and the screen fit's detector
// systematic and lens model misfit rows, which its budget propagates to the curvature and the camera positions,
// propagated here to the intrinsics through the same linearized refit. The rows are independent: the combined
// covariance is their sum. It is what the calibration states (the sidecar, the projection map, the precision check).
struct FromScreenIntrinsicsBudget {
  struct Row {
    std::string name, type, source;  // "detection noise" (A), "detector systematic" (B), "lens model misfit" (A)
    Eigen::MatrixXd covariance;      // intrinsics, mrcal's order and units
    double dof = std::numeric_limits<double>::infinity();
  };
  bool computed = false;  // false: only the noise row is stated (note says why)
  std::string note;
  std::vector<Row> rows;
  Eigen::MatrixXd combined;
  double dof = std::numeric_limits<double>::infinity();  // Welch-Satterthwaite over the rows
  int observations = 0;                                   // inliers linearized
  // Checks of the rebuilt linearization against the fit: the largest difference of the residuals (px) and the
  // relative (Frobenius) difference of the noise row rebuilt from it against the fit's own covariance.
  double residual_check_px = 0, noise_check = 0;
  // The lens's departure from any model of this family that no intrinsics can follow: the screen fit's measured
  // misfit components (Gaussian and ring fields, UncertaintyBudget::FieldComponent) and their summed variance per
  // coordinate (px^2), what a comparison with the true lens (not with another calibration of it) adds per point
  // (projection_compare.h LensWithCovariance::unmodelled).
  std::vector<UncertaintyBudget::FieldComponent> unmodelled;
  double unmodelled_variance_px2 = 0;
};

struct LensCandidateFit {
  std::string lensmodel;
  int intrinsics = 0;  // parameter count of the lens model
  std::string error;   // non-empty: the fit failed (its message)
  ScreenFitResult fit;
  double bic = 0, rms_px = 0, noise_px = 0;
};

struct FromScreenResult {
  Monitor monitor;
  int width = 0, height = 0;
  double focal_seed_px = 0;
  std::string focal_seed_source;  // "EXIF ...", "--focal-px"
  std::vector<std::string> photos;
  std::vector<LensCandidateFit> candidates;
  int chosen = -1;
  std::string choice;
  CameraModel model;  // the chosen candidate's lens
  // The chosen lens's intrinsics covariance as stated (intrinsics_budget.combined: every row of the budget), and
  // the budget itself.
  Eigen::MatrixXd intrinsics_covariance;
  FromScreenIntrinsicsBudget intrinsics_budget;
  FromScreenObservability observability;
  // The screen from the chosen candidate (its cylinder, or flat): radius and its combined sigma (the screen fit's
  // budget over the joint covariance), empty when flat or not a number.
  std::optional<double> radius_mm, radius_sigma_mm;
  std::array<double, 2> radius_ci95_mm{};
  FromScreenProjection projection;
  // precise: the median projection sigma over the covered cells is within the limit. When not, `suggested` holds
  // the positions to add (SuggestPositions).
  bool precise = true;
  std::vector<SuggestedPosition> suggested;
  const LensCandidateFit& Chosen() const { return candidates.at(static_cast<size_t>(chosen)); }
};

// The observations of one photo in memory (gray, CV_8U or CV_16U) named `name`: the features of `pattern` that
// DetectFeatures found unflagged, with their display positions. Throws Error naming the photo when the pattern is
// not detected.
PhotoObservations ObserveScreenImage(const cv::Mat& gray, const std::string& name, const PatternFile& pattern,
                                     const DetectOptions& options);

// Detects the pattern of `pattern` in each photo (detect/detect.h) and returns its observations for the fit
// (flagged features left out). All photos must have one size (returned in width, height). Throws Error naming
// the photo when it cannot be read, has another size, or does not show the pattern.
std::vector<PhotoObservations> ObserveScreenPhotos(const std::vector<std::filesystem::path>& photos,
                                                   const PatternFile& pattern, const DetectOptions& options,
                                                   int* width, int* height);

// The focal length seed (px) from EXIF tags (capture/exif.h ReadExif's object): the 35 mm equivalent focal
// length f35 scaled by the image diagonal, f = f35 sqrt(W^2 + H^2) / 43.27 (a 36 x 24 mm frame's diagonal);
// empty without that tag.
std::optional<double> FocalSeedFromExif(const nlohmann::json& exif, int width, int height);

// Calibrates from the photos' observations of the monitor `monitor` (its pitch fixes the scale). Throws Error for
// too few photos, photos too similar to separate focal length from distance, or a fit that does not make the
// focal length observable: each error names the photos, the problem with its figures, and what to add.
FromScreenResult CalibrateFromScreen(const std::vector<PhotoObservations>& photos, const Monitor& monitor, int width,
                                     int height, const FromScreenOptions& options);

// The intrinsics' budget of candidate fit `m` (with free intrinsics) of `photos` on `monitor`, `model` its lens
// (FromScreenIntrinsicsBudget; how: calibrate/from_screen_budget.cc). `options`: the fit's options (the systematic
// field degree, the misfit features).
FromScreenIntrinsicsBudget IntrinsicsBudgetFromScreen(const std::vector<PhotoObservations>& photos,
                                                      const Monitor& monitor, const CameraModel& model,
                                                      const ModelFit& m, const FitOptions& options);

// Positions that break the focal length / distance coupling further, from the fitted cameras: at the photos'
// median distance from the screen centre, aimed at it, yawed to +-max(35 deg, the widest yaw so far + 10 deg)
// left and right of the screen's normal, and tilted +-15 deg above and below. Foreshortening from wide yaws is
// what separates f from d (the header); on `bench calibrate --from-screen` seed 3 adding the two yawed photos cut
// the median projection sigma over the covered area from 0.22 to 0.10 px and the error against the truth from 0.44
// to 0.08 px (the two tilted ones: to 0.13 px and 0.28 px; a nearer one: no change).
std::vector<SuggestedPosition> SuggestPositions(const FromScreenResult& r);

// The candidate table, the choice, the observability statement and the radius, as `calibrate --from-screen`
// prints them.
std::string FromScreenSummary(const FromScreenResult& r);

// CAM.calibration.json of a calibration from the screen (format curvecheck.calibration_from_screen/1): the method,
// the seed, the candidates, the chosen lens model with its intrinsics and their covariance, the observability,
// `screen` {model, radius_mm, radius_sigma_mm, radius_ci95_mm, budget}, per photo the camera position (screen
// frame) and RMS.
nlohmann::json FromScreenJson(const FromScreenResult& r);

// The intrinsics covariance sidecar (calibrate.h IntrinsicsCovarianceJson's format) of the chosen candidate, so
// that `analyze` propagates this calibration's lens uncertainty.
nlohmann::json FromScreenCovarianceJson(const FromScreenResult& r, const std::string& model_file);

// A model against a true one (synthetic photos): both unproject a grid of gridn_width x gridn_height pixel centres
// over the imager; the true rays are put at distance_mm; the rotation that best maps the true rays onto the
// recovered model's rays within min(W, H)/6 of the imager centre is fitted (Kabsch; mrcal's projection_diff
// without uncertainties fits its implied transform in the same region), and each true point is projected by the
// recovered model through it. Returns |difference| per grid point (px), row-major.
std::vector<double> LensDifferencePx(const CameraModel& truth, const CameraModel& estimate, int gridn_width,
                                     int gridn_height, double distance_mm);

}  // namespace curvecheck
