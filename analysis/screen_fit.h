// The screen fit (issue 6 items 3-5): Ceres over all photos jointly, one pose per photo and one screen model
// (analysis/screen_model.h), model selection by BIC and held-out features, and the deviation of the physical
// screen from the chosen surface along its normal.
//
// Frames: the fitted screen's CENTRE frame (origin at the screen centre, x right, y up, +z toward the viewer);
// camera frame x right, y down, z forward; pixels in mrcal's convention (centres at integers).
// Residual of observation i of photo p (px):  r = q(X) - q_detected,  X = centre_from_cam_p^T (P(u, v; shape)
// - c_p), with q the mrcal lens model (libmrcal through core/camera_model.h, with its gradient dq/dX), c_p the
// camera position in the centre frame and P the model surface point. The lens model and the pixel pitch are
// fixed (the photos cannot tell a larger, farther screen from a smaller, nearer one).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/screen_model.h"
#include "core/camera_model.h"
#include "core/error.h"
#include "core/monitor.h"
#include "core/pose.h"

namespace curvecheck {

struct PhotoObservations {
  std::string photo;                         // a name for reports
  std::vector<std::string> ids;              // feature ids (the same id in several photos is the same feature)
  std::vector<Eigen::Vector2d> display_px;   // the features' display positions (pattern.json)
  std::vector<Eigen::Vector2d> detected_px;  // in the camera image
  // The random part of the detections' error, RMS px per coordinate, its standard uncertainty and how many corner
  // coordinates measured it (detect.h RefinementNoise: the refinement's response to the photo's own noise; 0
  // samples: not measured). The detector-systematic row's smooth bound leaves it out (FitOptions::smooth_bias_px).
  double random_error_px = 0;
  double random_error_u_px = 0;
  long random_error_samples = 0;
};

struct FitOptions {
  // Models to try (names parsed at the edges: ParseScreenModels), reported in order of complexity whatever the
  // order here. Default: all of them.
  std::vector<ScreenModelKind> models = AllScreenModels();
  // Expected detection noise per coordinate (px): scales the robust loss. Detectors give 0.02-0.2 px.
  double expected_noise_px = 0.15;
  // Measured detection noise per coordinate (camera px), from a source independent of the screen model (the
  // analysis sets it from the verification's scatter: each photo's residuals about a smooth field beyond a
  // homography). Every candidate is tested against it (ModelFit::adequate). 0 = unknown: expected_noise_px is
  // used instead and the result says that the noise was assumed (ScreenFitResult::detection_noise_assumed).
  double detection_noise_px = 0;
  // Adequacy of a candidate against the detection noise sigma (metrology.md section 3). A model is inadequate when
  // its misfit is both statistically and practically significant:
  //   chi2_p_value < adequacy_p_value  AND  noise_px > max(adequacy_noise_ratio sigma, sigma + noise_floor_px).
  // - Statistical, p < 1e-3: a correct model is called inadequate once in a thousand fits (at most 0.6% of
  //   fits over the six candidates). This is the test that decides on small samples: with dof = 20 a noise
  //   ratio of 1.5 happens by chance with p = 1e-3, so the ratio alone would fail correct models there.
  // - Practical, ratio 1.5: with thousands of residuals a misfit of a few percent of the noise is
  //   "significant" (dof = 5000: p < 1e-3 from a ratio of 1.03). At a ratio of 1.5 the systematic misfit,
  //   sqrt(1.5^2 - 1) = 1.1 sigma per coordinate, is larger than the detection noise itself. Below that the
  //   misfit is not cleanly separable from an error in sigma: sigma is measured by another estimator on other
  //   residuals (about a smooth field, per photo, heavy-tailed in real photos), and a 20-30% error in it is
  //   plausible; and a moderate misfit is not hidden, it inflates this model's sigmas, which are scaled by its
  //   own residual noise (noise_px).
  // - Floor, sigma + noise_floor_px: the detectors' systematic error (pixel-locking) is not Gaussian noise, and
  //   at small sigma (0.02-0.05 px) 1.5 sigma would call a model inadequate for misfits of 0.01-0.02 px that no
  //   screen model is about (pixel-locking, the lens calibration's own error). Model choice already treats
  //   residual differences below the floor as no evidence; the adequacy test must not contradict it. The
  //   linear sum (not the quadrature one) is the bound for a systematic error that adds to the noise.
  double adequacy_p_value = 1e-3;
  double adequacy_noise_ratio = 1.5;
  // Huber loss threshold in units of expected_noise_px: residuals beyond it weigh linearly in the first,
  // robust pass. 3 keeps ~99% efficiency on Gaussian noise.
  double huber_sigmas = 3;
  // An observation is an outlier when its residual length exceeds outlier_sigmas times the robust (MAD) noise
  // of the best-fitting model, and at least outlier_min_px. Outliers are left out of the final fits.
  double outlier_sigmas = 5;
  double outlier_min_px = 0.5;
  // k-fold cross-validation over features (by id, across photos); 0 turns held-out errors off (then the choice
  // rests on BIC alone). Each fold is refitted from the full fit's solution (heldout_exact_refit says how).
  int heldout_folds = 5;
  // How a fold is refitted: false, one Gauss-Newton step from the full fit's solution through its linearization
  // (the normal matrix and gradient less the fold's rows; a few small t x t solves); true, a Ceres solve per fold
  // (heldout_folds solves over every residual per candidate: 30% of a ten-photo fit's time). The step is what a
  // solver started at the full solution takes first; both agree to well within heldout_tolerance (the fit's
  // tests compare them). The step is used only where the final fit's linearization exists; otherwise the solves.
  bool heldout_exact_refit = false;
  // The held-out error again with the features' folds made of contiguous strips of the screen (heldout_folds strips
  // across u, the display's horizontal coordinate) instead of a shuffle (ModelFit::heldout_strips_px), and a
  // richer candidate left out of the choice when a simpler adequate one predicts the left-out strips better by more
  // than heldout_tolerance. Shuffled folds leave each feature's neighbours in the fit, so an error correlated
  // between neighbours (a detector's moire) is predicted from them and a richer model that fits it looks better
  // there as under BIC; a strip has no such neighbours, and a shape that is not the screen's does not carry over
  // to it (an independent tracer's moire, 2026-12-06: varying-curvature-quadratic chosen 3-5 sigma from the true
  // radius, its strip error 1.4-4.6 times the cylinder's; a true lean of 1 deg predicts the strips ten times
  // better than the cylinder). Not for cylinder+deviation: a local deviation's strip has no support elsewhere, so
  // no model predicts it from the rest (a true 2 mm bulge: the deviation model's strip error 2.3 times the
  // cylinder's); its choice stays with BIC and the shuffled folds. false: the shuffled folds alone.
  bool heldout_strips = true;
  // A richer model is chosen only if its BIC is lower than every simpler one's by more than bic_margin
  // (10: "very strong" evidence on Kass and Raftery's scale), and its held-out RMS is within
  // heldout_tolerance (relative) of the best held-out RMS. The rule runs among the adequate candidates (see
  // adequacy_p_value), or among all when none is adequate (ChooseModel).
  double bic_margin = 10;
  double heldout_tolerance = 0.05;
  // Systematic error floor of the detections, px per coordinate: residual differences below it are not evidence
  // for a richer model. Corner detectors lock to the pixel grid by a few hundredths of a pixel (cornerSubPix:
  // +-0.045 px, periodic across a board's columns, measured on a 1500 x 1000 synthetic photo against its
  // truth); without a floor, a quadratic curvature profile absorbed that pattern and moved the radius by 60 mm
  // (5 sigma). The BIC uses max(RSS, n floor^2) and held-out errors max(RMS, sqrt(2) floor). 0 turns it off.
  double noise_floor_px = 0.05;
  // Deviation field: B-spline coefficients across the width and the height (5 gauge modes are removed), and
  // a weak zero-mean prior on them (mm) that bounds what the photos cannot see (a surface seen along its
  // normal does not show a displacement along it).
  // 13 x 6 resolves a Gaussian of sigma 0.12 x 0.3 in (u, v) to 10% of its height (the 2 mm bulge scene); it
  // needs several hundred features to be chosen over the cylinder by BIC (73 parameters).
  int deviation_nu = 13;
  int deviation_nv = 6;
  double deviation_prior_mm = 5;
  // Deviation map: nu x nv samples over the screen, Gaussian smoothing of the per-feature deviations (in u, v
  // units), NaN where no feature lies within map_support_uv or the smoothed sigma exceeds map_max_sigma_mm.
  int map_nu = 41;
  int map_nv = 13;
  double map_smoothing_uv = 0.08;
  double map_support_uv = 0.15;
  double map_max_sigma_mm = 1.0;
  // Solver: iterations per fit.
  int max_iterations = 100;
  // A radius whose curvature sigma exceeds this fraction of |k| is not reported as a number (the fit is
  // ill-conditioned): at 0.25 the 95% interval of R spans more than a factor 3. Nearly flat views reach it.
  double max_relative_curvature_sigma = 0.25;
  // Fewer features per photo than this is an error (6 for the pose, plus margin for the shape).
  int min_features_per_photo = 8;

  // Uncertainty budget (metrology.md section 1; UncertaintyBudget below).
  // Lens calibration: the covariance of the camera model's intrinsics (mrcal's order and units: fx, fy, cx, cy in
  // px, then the distortion parameters), from the calibration (calibrate/ writes it beside the model,
  // ReadIntrinsicsCovariance). Empty: the lens is taken as exact and the budget's lens row is 0, with
  // lens_exact_note as its assumption. intrinsics_covariance_dof: the calibration's residual degrees of freedom
  // (Welch-Satterthwaite; infinity when unknown). intrinsics_covariance_source names the file.
  Eigen::MatrixXd intrinsics_covariance;
  double intrinsics_covariance_dof = std::numeric_limits<double>::infinity();
  std::string intrinsics_covariance_source;
  std::string lens_exact_note =
      "lens model taken as exact: no covariance beside the camera model; calibrate with curvecheck calibrate to get "
      "one (for a synthetic photo rendered through this very model the lens is exact)";
  // Pixel pitch: the relative tolerance of the datasheet's pitch (half-width of a rectangular distribution,
  // standard uncertainty tolerance/sqrt(3)). 0.1%: active areas are specified to 0.1 mm on ~600 mm.
  double pitch_tolerance_relative = 0.001;
  // Detector systematic: the bias fields (Legendre polynomials of total degree <= systematic_field_degree over
  // the image, independent N(0,1) coefficients per coordinate, each draw scaled to the bound's RMS) and the
  // number of seeded draws whose RMS effect is the standard uncertainty.
  int systematic_field_degree = 3;
  // RMS b of the smooth bias fields, px per coordinate (type B: a smooth detector bias cannot be told from the
  // screen's shape or the pose, so no photo measures b itself). Unset (the default): b is taken as large as the
  // detector's measured scatter about the fit once the pixel-locking signature is out (ResidualPixelLocking::
  // noise_px, the noise row's), times smooth_bias_scatter_fraction; the assumption is that a detector whose
  // errors vary little from corner to corner has little smooth error either, and that its smooth error is no
  // larger than its corner-to-corner scatter. Set: b as stated (0: no smooth bias). Until 2026-12-05 b was a
  // stated 0.02 px; bench validity --detector-effect measured the detector's own error's effect on the radius at
  // 0.08-1.60 times that row across resolution, distance and imaging chain (the row's constant had the wrong
  // shape: the detector's error grows with distance through the colour filter array's moire and shrinks with
  // resolution), and 0.13-0.88 times the row with b = the scatter (docs/bench/validity_bench.txt,
  // twenty-second section). A detector's smooth error measured on the truth (the noise-free photo's detections,
  // Legendre degree 3) is 0.14-1.26 times the scatter on that bench, median 0.76; the fields of independent
  // coefficients over-state its effect on the radius 1.2-6 times (the detector's own error is absorbed more by
  // the poses), so b = 1 x the scatter does not under-state it in any slice. Where the photos measured the
  // random part r of their detections' error (PhotoObservations::random_error_px), the scatter's deterministic
  // part replaces the scatter (screen_fit_internal.h SmoothBoundPx): random errors leave no smooth error. By
  // default the scatter's part that lattice neighbours share replaces it (smooth_bound_from_neighbours below).
  std::optional<double> smooth_bias_px;
  double smooth_bias_scatter_fraction = 1.0;
  // The scatter's part that is not smooth, measured on the residuals themselves (screen_fit_internal.h
  // WhiteScatterPx: second differences along the pattern's lattice) where enough lattice neighbours were fitted:
  // an error that neighbouring corners do not share (the sensor's noise, the refinement's response to a corner's
  // own pixels, a pixel-locking remainder of random phase) is counted by the detection-noise row and cannot add
  // up to a smooth field. It stands in for the refinement's noise response (random_error_px), which it contains.
  // false: the noise response as before (2026-12-07).
  bool smooth_bound_from_neighbours = true;
  // false: the pixel-locking signature is not fitted (no share in the detector-systematic row, the noise row
  // scaled by the whole residual noise, nothing removed before the misfit statistics): for tests of other rows on
  // detections with independent noise only, where a small patch cannot tell the signature from the curvature and
  // the row would (rightly) widen the interval on its own.
  bool measure_pixel_locking = true;
  // The pixel-locking signature's prior: each of its coefficients (but the tag border's) N(0,
  // pixel_locking_prior_px^2) before the photos (type B; 0 = none, the regression alone). It bounds the
  // coefficients the photos cannot determine (a shape whose refit projection is nearly nothing: the fit absorbs it)
  // instead of fitting them to the noise, and is negligible where they are determined. 0.1 px: a coefficient of
  // 0.1 px is an amplitude of 0.14 px; the well-determined amplitudes of the validity bench's synthetic detector
  // reach 0.13 px at quarter resolution (median 0.05 px), and pixel-locking of sub-pixel estimators on sharp,
  // undersampled edges is a fraction of a pixel.
  double pixel_locking_prior_px = 0.1;
  int systematic_field_draws = 2000;
  unsigned systematic_field_seed = 20261201;
  // Lens model misfit (the true lens's departure from the camera model, and any other error that is smooth over
  // the image and common to the photos): its RMS is measured from the residuals (their correlation between
  // neighbouring features, which independent noise does not have), under the assumption that it is a field of
  // Legendre polynomials of total degree <= misfit_field_degree over the image with independent N(0, 1)
  // coefficients per coordinate; the fraction of such a field that the fit leaves in the residuals is computed
  // from the fit's own linearization. 6: structure down to about a sixth of the image, finer than the
  // detector-systematic fields and coarser than the feature spacing (it must vary little between neighbours).
  int misfit_field_degree = 6;
  // Random Fourier features of the Gaussian field that the lens-model-misfit row propagates
  // (EstimateMisfitCorrelation): 400 give its covariance to about 0.07 of the variance per pair.
  int misfit_features = 400;
  // false: no lens-model-misfit row (the lens taken as exact beyond its calibration covariance), for tests of
  // other rows and for a lens known to be modelled exactly (the clean synthetic camera).
  bool measure_lens_misfit = true;
  // The lens model misfit as the calibration measured it (type B here): a Gaussian field of RMS
  // stated_lens_misfit_px per coordinate and correlation length stated_lens_misfit_length_px, common to every photo.
  // curvecheck calibrate measures it from the residuals' correlation between its photos and writes it into the
  // intrinsics covariance sidecar ("misfit"); analyze --lens-misfit states it. The lens-model-misfit row is then the
  // larger, in the curvature's variance, of this field propagated through the fit and the field measured from the
  // photos' own residuals: one photo cannot tell the variance of a field much longer than its feature spacing,
  // which the fit mostly absorbs (docs/bench/validity_bench.txt, 2026-12-04: the row from the residuals alone
  // was 0.05-19x the field's effect trial by trial). 0: none stated (the row is the measured field alone).
  double stated_lens_misfit_px = 0;
  double stated_lens_misfit_length_px = 0;
  std::string stated_lens_misfit_source;
  // The largest lens model misfit (RMS px per coordinate, as a fraction of the image width) that the model choice
  // and the adequacy test accept as one (ScreenFitResult::lens_field_px): 1e-4, 0.6 px on a 6000 px imager. A
  // calibrated lens model misfits by less than its calibration's residual: mrcal's tour reports 0.4 px RMS for
  // OPENCV8 and 0.2 px for its splined model on a 6000 px camera (both with the detection noise in them); the
  // synthetic presets use 0.1-0.2 px at 6000 px. Smooth residuals beyond it are a wrong screen model or wrong data.
  double max_lens_misfit_relative = 1e-4;
  // Coverage probability of the interval (the coverage factor is Student's t at the effective degrees of freedom).
  double coverage_probability = 0.95;
  // Self-calibration (calibrate/from_screen.h): the camera model's intrinsics are free parameters of every
  // candidate, seeded by the given model and estimated jointly with the poses and the shape (ReprojectionCost with
  // free intrinsics: libmrcal's dq/dintrinsics). The covariance is then the joint one: the detection noise row
  // holds the lens's uncertainty (marginalised), the lens calibration row is empty, and ModelFit::intrinsics* are
  // set. The pixel pitch (the screen's known size) fixes the scale that couples focal length and distance.
  bool fit_intrinsics = false;

  // Throws Error naming `where` for values out of range or unknown model names.
  void Check(const std::string& where) const;
};

struct CameraEstimate {
  // The camera in the centre frame as fitted: the pose that reproduces the residuals (its translation the camera
  // centre there, mm, before the pixel-locking correction).
  Pose centre_from_cam;
  // The camera centre in the centre frame (mm): the pose's translation corrected for the fitted pixel-locking
  // signature (UncertaintyBudget::pixel_locking_correction_*), with its sigma (per axis: the pose's covariance
  // scaled by the model's noise_px, then the budget's combined uncertainty).
  Eigen::Vector3d position_in_centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_in_centre_sigma_mm = Eigen::Vector3d::Zero();
  // In the architecture's screen frame: origin on the fitted axis (centre frame shifted by -R in z); the centre
  // frame itself when the radius is not a number (flat within its interval). Its sigma is this frame's: x and y
  // as in the centre frame, z = c_z - R propagated with the covariance of the position and the curvature,
  // their cross-covariance included, var = var(c_z) + var(k)/k^4 + 2 cov(c_z, k)/k^2 (R = 1/k): about the
  // radius's sigma, as the centre-frame z is far better determined than the radius. NaN where the covariance
  // could not be computed.
  Eigen::Vector3d position_in_screen_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_in_screen_sigma_mm = Eigen::Vector3d::Zero();
};

// One row of the uncertainty budget: a standard uncertainty of the curvature k = 1/R, of the radius and of the
// first camera's position, from one source (GUM, JCGM 100:2008 section 5: rows combined in quadrature).
// How a budget row's error is distributed: the coverage factor depends on it (JCGM 100 G.2.3: a rectangular
// distribution of standard uncertainty u lies wholly within +- sqrt(3) u, and 95% of it within +- 1.645 u).
// A stated lens misfit is a field scaled to its stated RMS over the imager (FitOptions::stated_lens_misfit_px):
// its error is not normal (kSampled: drawn, NormalisedField).
enum class RowDistribution { kNormal, kRectangular, kSampled };
const char* RowDistributionName(RowDistribution d);  // "normal", "rectangular", "sampled"

struct BudgetComponent {
  std::string name;  // "detection noise", "detector systematic", "lens calibration", "pixel pitch"
  std::string type;  // "A" (evaluated from the data's statistics) or "B" (from other information)
  RowDistribution distribution = RowDistribution::kNormal;
  std::string source, assumption;
  double curvature_per_mm = 0;  // u(k), 1/mm
  double radius_mm = 0;         // u(R) = u(k)/k^2 (linearized), NaN when the radius is not a number
  // The first camera's position: in the axis frame (CameraEstimate::position_in_screen_mm) and the centre frame.
  Eigen::Vector3d position_in_axis_mm = Eigen::Vector3d::Zero(), position_in_centre_mm = Eigen::Vector3d::Zero();
  double dof = std::numeric_limits<double>::infinity();  // degrees of freedom (infinity for type B)
};

// The detector's pixel-locking signature measured through the fit: per coordinate c and period T a bias
// a sin 2 pi phi + b cos 2 pi phi, phi the phase of the fit's prediction q in that period (frac(q / T)); periods 1 px
// (the sampling) and 2 px (a Bayer colour filter array repeats every 2 px, and its demosaicing error with it;
// measured 0.05 px with the CFA on, 0.004 px without, docs/bench/validity_bench.txt 2026-12-05). The coefficients
// reach the residuals through the refit as P sin, P cos (P = I - J (J^T J)^+ J^T), so they are fitted to the
// residuals on those projected shapes (screen_fit_internal.h FitPixelLocking): unbiased where the fit absorbs part
// of the signature (a frontal view of a regular board, whose phases beat slowly across the image). The budget
// corrects the curvature and the camera positions for the fitted signature (UncertaintyBudget::
// pixel_locking_correction_*). The same fit holds more of the detector's signature (screen_fit_internal.h
// SignatureLayout): the 2 px period's cross-phase terms and, on a checkerboard, the corner's polarity; without them,
// on a frontal board from 3 m at quarter resolution, the camera's lateral position was covered by 171 of 200 95%
// intervals (docs/bench/validity_bench.txt, thirty-ninth section).
inline constexpr int kPixelLockingTerms = 2;
inline constexpr std::array<double, kPixelLockingTerms> kPixelLockingPeriods = {1.0, 2.0};  // px
struct ResidualPixelLocking {
  // sqrt(a^2 + b^2): row = coordinate (x, y), column = period (1 px, 2 px)
  Eigen::Matrix2d amplitude_px = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d sigma_px = Eigen::Matrix2d::Zero();  // its standard uncertainty
  int observations = 0;
  // The residuals' RMS per coordinate once the fitted signature is removed (over 2n - parameters - the signature's
  // columns degrees of freedom: 20, + 2 with tags, + 10 on a checkerboard; screen_fit_internal.h SignatureLayout):
  // the independent detection noise, which the detection-noise row propagates (the fit's noise_px holds the
  // signature's power too, which the correction removes). NaN: not measured.
  double noise_px = std::numeric_limits<double>::quiet_NaN();
  // Tags (screen_fit_internal.h PixelLockingShapes): the detector's shift of the tags' black border edges, x and y,
  // px, positive outward, fitted with the signature and corrected for like it; its standard uncertainty; and the tag
  // corners it was fitted on (0 and NaN: no tags, or fewer than four with all four corners).
  Eigen::Vector2d tag_border_shift_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector2d tag_border_shift_sigma_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  int tag_border_corners = 0;
  // Checkerboards (screen_fit_internal.h SignatureLayout): the part of the detector's error that changes sign with
  // the corner's polarity (the two mirror-image saddles of a checkerboard alternate), x and y, px, at the mean over
  // the colour filter array's 2 x 2 cell (its phase-dependent part is fitted too, not reported); its standard
  // uncertainty; and the corners it was fitted on (0 and NaN: no checkerboard, or its layout unread).
  Eigen::Vector2d polarity_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector2d polarity_sigma_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  int polarity_corners = 0;
};

struct UncertaintyBudget {
  bool computed = false;
  std::string note;  // why a component could not be computed, if so
  std::vector<BudgetComponent> components;
  BudgetComponent combined;  // quadrature sum (name "combined")
  double effective_dof = 0;  // Welch-Satterthwaite over the components' dof
  // For FitOptions::coverage_probability, on the curvature: CoverageFactor over the rows (Student's t at the normal
  // rows' Welch-Satterthwaite dof, convolved with the rectangular row; t alone when there is none).
  double coverage_factor = 0;
  double coverage_probability = 0.95;
  // The same at kCoverage68 (the level of one standard uncertainty of a normal distribution): the 68% interval,
  // which is +- u_c only when the normal rows dominate (a rectangle of standard uncertainty u holds 57.7% within
  // +- u, and 68.3% within +- 1.18 u).
  double coverage_factor68 = 0;
  // Both for the first camera's position, per coordinate, in the axis frame and the centre frame (their rows in
  // BudgetComponent::position_in_axis_mm, position_in_centre_mm); FinishBudget.
  struct PositionFactors {
    Eigen::Vector3d axis = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
  };
  PositionFactors position_factor, position_factor68;
  std::string dominant;  // the component with the largest u(k)
  std::array<std::string, 3> dominant_position;  // per axis (axis frame)
  ResidualPixelLocking pixel_locking;
  double systematic_bound_px = 0;  // b: the smooth bias, RMS per coordinate of the fields (stated or scaled)
  std::string systematic_bound_reason;
  // The scatter's part that lattice neighbours do not share (FitOptions::smooth_bound_from_neighbours), px per
  // coordinate, the standard uncertainty of s^2 less its square under white errors (px^2), and the second
  // differences it is taken from (0: too few; NaN values).
  double white_scatter_px = std::numeric_limits<double>::quiet_NaN();
  double white_scatter_u_difference_px2 = std::numeric_limits<double>::quiet_NaN();
  int white_scatter_triples = 0;
  // The detection-noise row's assumption tested (screen_fit_internal.h NoiseIndependenceCheck): are the residuals
  // (without the pixel-locking signature) of lattice neighbours independent? Pairs of neighbours on the screen from
  // the white scatter's triples, along its rows (s) and along its columns (y). Per coordinate (row: camera x, y) and
  // direction (column: along the screen's rows, along its columns) the neighbours' correlation r, its expectation
  // r0 were the errors independent (what the fit makes of them) and z = (r - r0) sqrt(pairs). A check, not used by
  // the row (docs/bench/validity_bench.txt, forty-first section): at 3 m, 40 deg, quarter resolution, the detector's
  // error alternates from row to row and the row overstates the camera's height (fortieth section). tested = false:
  // fewer than kMinWhiteTriples triples, or no linearization; NaN entries: fewer than kMinWhiteTriples pairs.
  static constexpr double kNoiseIndependenceZ = 3;
  struct NoiseIndependence {
    bool tested = false;
    bool independent = true;  // every measured |z| < kNoiseIndependenceZ (3)
    std::array<int, 2> pairs = {0, 0};  // along the screen's rows, along its columns
    Eigen::Matrix2d correlation = Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
    Eigen::Matrix2d null_correlation = Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
    Eigen::Matrix2d z = Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
    std::string summary;  // one sentence, also appended to the detection-noise row's assumption
  };
  NoiseIndependence noise_independence;
  // The detector-systematic row's two parts, u(k) (1/mm): the smooth fields and the pixel-locking correction's
  // uncertainty.
  double smooth_share_curvature_per_mm = 0, pixel_locking_share_curvature_per_mm = 0;
  // The correction applied for the fitted pixel-locking signature (-G S b, the linearized fit with its coefficients
  // as nuisance parameters): to the curvature (1/mm; the reported one includes it) and to the first camera's
  // position (centre frame, mm; the reported positions include it). 0 when the signature was not fitted. The fitted
  // surface, the rotations and the deviations are the uncorrected fit's.
  double pixel_locking_correction_curvature_per_mm = 0;
  Eigen::Vector3d pixel_locking_correction_position_mm = Eigen::Vector3d::Zero();
  // The correction's standard uncertainty for the first camera's position (centre frame, mm, per axis; the
  // curvature's is pixel_locking_share_curvature_per_mm): part of the detector-systematic row.
  Eigen::Vector3d pixel_locking_correction_sigma_position_mm = Eigen::Vector3d::Zero();
  // The lens-model-misfit row: the neighbour statistic (mean over neighbour pairs of r_i . r_j / 2, px^2), the
  // independent noise's expected share of it, the fraction kappa of a unit-RMS misfit field that the statistic
  // sees after the fit, and the field's RMS estimate and upper bound (estimate + 2 sigma of the statistic under
  // noise), px per coordinate. NaN when not computed.
  double misfit_statistic_px2 = std::numeric_limits<double>::quiet_NaN();
  double misfit_noise_share_px2 = std::numeric_limits<double>::quiet_NaN();
  double misfit_kappa = std::numeric_limits<double>::quiet_NaN();
  double misfit_estimate_px = std::numeric_limits<double>::quiet_NaN();
  double misfit_bound_px = std::numeric_limits<double>::quiet_NaN();
  int misfit_pairs = 0;
  // The misfit field's correlation (EstimateMisfitCorrelation in screen_fit_misfit.cc): the residuals' statistic at
  // several lags fitted by a stationary Gaussian field of variance misfit_variance_px2 (s^2 per coordinate, its
  // standard error misfit_variance_sd_px2) and correlation length misfit_length_px; what the row propagates.
  // misfit_spacing_px: the median nearest-neighbour distance the lags are counted in. NaN when not computed.
  struct Lag {
    double lag_spacings = 0;  // mean pair distance in feature spacings
    int pairs = 0;
    double statistic_px2 = 0, noise_share_px2 = 0, field_share_px2 = 0;
  };
  // The components' families: kGaussian, covariance s^2 exp(-d^2 / 2 L^2) (L = length_px), positive at every lag;
  // kRing, covariance s^2 J0(2 pi d / P) (P = length_px, the period), a band-pass field whose correlation changes
  // sign (a beat of the features' spacing against a pixel grid).
  enum class FieldFamily { kGaussian, kRing };
  struct FieldComponent {
    FieldFamily family = FieldFamily::kGaussian;
    double length_px = 0, variance_px2 = 0, variance_sd_px2 = 0;
  };
  // Up to two Gaussian components (short-range, then long-range) and one ring, each propagated.
  std::vector<FieldComponent> misfit_components;
  double misfit_length_px = std::numeric_limits<double>::quiet_NaN();
  double misfit_variance_px2 = std::numeric_limits<double>::quiet_NaN();
  double misfit_variance_sd_px2 = std::numeric_limits<double>::quiet_NaN();
  double misfit_spacing_px = std::numeric_limits<double>::quiet_NaN();
  double misfit_fit_chi2 = std::numeric_limits<double>::quiet_NaN();
  std::vector<Lag> misfit_lags;
  // The row's two candidates, u(k) (1/mm): the field measured from the residuals and the stated one
  // (FitOptions::stated_lens_misfit_px, NaN when none is stated); misfit_row_basis names the one the row took
  // ("residuals" or "calibration"); the measured one's standard uncertainty (from its variances' standard
  // uncertainties, delta method), by which the row's rule judges whether it exceeds the stated one.
  double measured_misfit_share_curvature_per_mm = std::numeric_limits<double>::quiet_NaN();
  double measured_misfit_share_sd_curvature_per_mm = std::numeric_limits<double>::quiet_NaN();
  double stated_misfit_share_curvature_per_mm = std::numeric_limits<double>::quiet_NaN();
  std::string misfit_row_basis;
};

struct ModelFit {
  std::string model;   // ScreenModelName
  int parameters = 0;  // screen parameters + 6 per photo
  // rms_px: RMS length of the 2D residual over the inliers; bic = n ln(RSS/n) + p ln(n) with n = 2 x inliers;
  // heldout_rms_px: RMS length of the residuals of features left out of the fit (k-fold), NaN when off.
  double rms_px = 0, bic = 0, heldout_rms_px = 0;
  // Model choice with the lens model misfit as a correlated error (ScreenFitResult::lens_field_px): the residual
  // covariance is sigma^2 I + B T B^T, B the misfit family's fields (FitOptions::misfit_field_degree, the same field
  // in every photo), T their coefficients' prior of RMS lens_field_px. lens_field_rss_px2: the part of the inliers'
  // residual sum that such a field explains (after the linearized refit of this model's parameters, with the
  // prior's penalty); bic, chi2 and the adequacy test then use RSS - lens_field_rss_px2 and heldout_rms_px is
  // compared as sqrt(heldout^2 - lens_field_rss_px2 / inliers) (heldout_adjusted_px). bic_white: the BIC of the
  // plain residual sum. NaN (and bic = bic_white) when no misfit was measured.
  double lens_field_rss_px2 = std::numeric_limits<double>::quiet_NaN();
  // The held-out RMS with the folds as strips of the screen (FitOptions::heldout_strips); NaN when off and for
  // cylinder+deviation. vetoed: a simpler adequate candidate's strip error is below this one's by more than
  // heldout_tolerance, so the choice left this one out.
  double heldout_strips_px = std::numeric_limits<double>::quiet_NaN();
  bool vetoed = false;
  double bic_white = std::numeric_limits<double>::quiet_NaN();
  double heldout_adjusted_px = std::numeric_limits<double>::quiet_NaN();
  // Per-coordinate noise of this model's residuals, sqrt(RSS/(n - p)); scales this model's covariance.
  double noise_px = 0;
  // Goodness of fit against the detection noise sigma (ScreenFitResult::detection_noise_px), over the inliers:
  // chi2 = RSS / sigma^2, dof = n - p (n = 2 x inliers, p = parameters; for cylinder+deviation the prior makes
  // the effective p smaller, so its chi2/dof is slightly optimistic), chi2_p_value = P(X >= chi2) for X
  // chi-square with dof degrees of freedom (exact: the regularized upper incomplete gamma Q(dof/2, chi2/2), no
  // normal approximation), noise_ratio = noise_px / sigma = sqrt(chi2 / dof). adequate: the misfit is not both
  // statistically and practically significant (FitOptions::adequacy_p_value); an inadequate model's parameters
  // are not measurements. adequacy_note says why, with the figures, when it is not adequate.
  double chi2 = 0;
  int dof = 0;
  double chi2_p_value = 1, noise_ratio = 0;
  bool adequate = true;
  std::string adequacy_note;
  // Curvature k = 1/R (for varying curvature: its mean over the width, k0 + k2/3), corrected for the fitted
  // pixel-locking signature (budget.pixel_locking_correction_curvature_per_mm; `shape` and `extra` are the
  // uncorrected fit's), and its sigma: the combined standard uncertainty of the budget (every source);
  // curvature_noise_sigma_per_mm is the detection noise's share alone (the covariance scaled by the residual noise
  // without the signature, budget.pixel_locking.noise_px). radius_sigma_mm, radius_ci95_mm and the cameras' sigmas
  // are the combined ones; the interval is k +- coverage_factor u_c(k), inverted.
  double curvature_per_mm = 0, curvature_sigma_per_mm = 0, curvature_noise_sigma_per_mm = 0;
  UncertaintyBudget budget;
  std::optional<double> radius_mm, radius_sigma_mm;  // empty when flat is inside the 95% interval
  double radius_lower_bound_mm = 0;                  // 95% lower bound of |R| when the radius is not a number
  std::array<double, 2> radius_ci95_mm{};            // from k +- 1.96 sigma_k, inverted (+inf when it holds 0)
  // The 68% interval, k +- budget.coverage_factor68 sigma_k inverted, when the radius is a number (NaN otherwise).
  std::array<double, 2> radius_ci68_mm{std::numeric_limits<double>::quiet_NaN(),
                                       std::numeric_limits<double>::quiet_NaN()};
  std::map<std::string, std::pair<double, double>> extra;  // e.g. "lean_deg" -> (value, sigma)
  std::vector<CameraEstimate> cameras;                     // one per photo
  // Per photo, per observation (detected - predicted); NaN where the fitted point falls behind the camera.
  std::vector<std::vector<Eigen::Vector2d>> residual_px;
  std::vector<std::vector<bool>> outlier;                  // left out of the final fit
  // Ill-conditioning: the covariance is rank-deficient, or the radius is not observable from these photos (the
  // curvature's 95% interval holds both flat and the nominal, or its sigma exceeds
  // FitOptions::max_relative_curvature_sigma of |k|). Then radius_mm is empty: no number is reported.
  bool ill_conditioned = false;
  std::string condition_note;  // e.g. "radius unobservable: ..."
  double time_ms = 0;          // this model's fits (robust, final, covariance, held-out folds)
  bool converged = false;
  int iterations = 0;  // solver iterations, robust and final pass (held-out folds not counted)
  // Shape parameters as fitted (CoreParameterCount values, then the deviation coefficients).
  std::vector<double> shape;
  // With FitOptions::fit_intrinsics: the fitted intrinsics (mrcal's order), their covariance scaled by noise_px^2
  // (a block of the joint covariance: marginal over poses and shape), their covariance with the curvature k
  // (1/mm x the intrinsic's unit), and per photo the correlation of fx with the camera's distance from the screen
  // centre (the focal/distance coupling). Empty otherwise, or when the covariance could not be computed.
  std::vector<double> intrinsics;
  Eigen::MatrixXd intrinsics_covariance;
  Eigen::VectorXd intrinsics_curvature_cov;
  std::vector<double> focal_distance_correlation;
  // cylinder+deviation: the curvature its deviation basis was built around (the cylinder's robust fit, or the
  // nominal when the cylinder was not fitted); 0 for the other models. FittedSurfacePointsInCamera needs it.
  double deviation_basis_curvature_per_mm = 0;
};

struct FeatureDeviation {
  int photo = 0;
  std::string id;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  double normal_mm = 0, sigma_mm = 0;  // along the surface normal, toward the viewer; sigma from noise_px
  bool outlier = false;
};

struct ScreenFitResult {
  std::vector<ModelFit> candidates;  // every model tried, in order of complexity
  int chosen = -1;                   // index into candidates
  std::string choice_reason;         // "BIC and held-out error both favour cylinder", ...
  double noise_px = 0;               // the chosen model's residual noise (per coordinate), scales its covariance
  // Per feature and photo: displacement along the normal of the chosen model's base surface (its cylinder for
  // cylinder+deviation, plus the fitted field) that explains the residual, mm.
  std::vector<FeatureDeviation> deviations;
  // Smoothed deviation map: map_nv rows of map_nu values (u fastest, u and v from -1 to 1 at the cell
  // centres), mm, NaN where unsupported; map_sigma_mm alike.
  int map_nu = 0, map_nv = 0;
  std::vector<double> map_mm, map_sigma_mm;
  std::vector<std::string> assumptions;  // "pixel pitch fixed from the spec: ...", "lens model fixed: ..."
  // Models of options.models that were not tried, each with the reason (too few residuals for its parameters:
  // fewer than 3 per parameter, e.g. the deviation field on a 15 x 4 board).
  std::vector<std::string> skipped;
  // The detection noise (px per coordinate) the candidates were tested against: FitOptions::detection_noise_px,
  // or expected_noise_px when that was 0 (then detection_noise_assumed, and an assumption says so). A model is
  // inadequate beyond noise_px > adequacy_limit_px = max(adequacy_noise_ratio sigma, sigma + noise_floor_px)
  // (and chi2_p_value < adequacy_p_value).
  double detection_noise_px = 0;
  bool detection_noise_assumed = false;
  // The lens model misfit's RMS (px per coordinate) the choice took as a correlated error (ModelFit::
  // lens_field_rss_px2): the smallest estimate over the converged candidates (from their residuals' energy in the
  // field family beyond the noise's share; the one least inflated by screen-shape error), capped at
  // FitOptions::max_lens_misfit_relative of the image width; 0 when not measured or no candidate shows a field
  // (then the choice and the adequacy test are the white-noise ones).
  double lens_field_px = 0;
  double adequacy_limit_px = 0;
  // "inadequate" when the chosen model is not adequate (no candidate fits the photos to their noise; takes
  // precedence), else "ill_conditioned" when the chosen model or the cylinder candidate is ill-conditioned (the
  // radius cannot be measured from these photos), else "ok". warnings: one line per ill-conditioned candidate
  // with its reason; the inadequacy of the chosen model with the figures and the likely causes; a radius
  // implausible against the nominal (beyond both 5 sigma and 25% of it), a flat screen measured on a monitor
  // specified curved, or a curved one on a monitor specified flat.
  std::string status = "ok";
  std::vector<std::string> warnings;

  const ModelFit& Chosen() const { return candidates.at(static_cast<size_t>(chosen)); }
};

// Too few observations for any model of FitOptions::models (3 residuals per parameter): FitScreen's typed error, so
// that the pipeline reports too few features rather than a solver failure.
class TooFewObservationsError : public Error {
 public:
  using Error::Error;
};

// Fits every model of options.models to the photos and picks one (see FitOptions). Throws Error for invalid
// input (no photos, mismatched sizes, too few features, non-finite numbers, an invalid camera or monitor), and
// TooFewObservationsError when no model has 3 residuals per parameter.
// A fit that does not converge or is ill-conditioned is a result (ModelFit.converged, ill_conditioned), not
// an error.
ScreenFitResult FitScreen(const Monitor& nominal, const CameraModel& camera,
                          const std::vector<PhotoObservations>& photos, const FitOptions& options);

// The choice among result->candidates (sets chosen and choice_reason; FitScreen calls it): among the converged
// adequate candidates (all converged ones if none is adequate), the simplest whose BIC is within
// options.bic_margin of the lowest and whose held-out RMS, floored at sqrt(2) options.noise_floor_px, is within
// options.heldout_tolerance (relative) of the lowest; the lowest BIC when none qualifies or nothing converged.
// Before that, a candidate whose strip held-out error (ModelFit::heldout_strips_px) exceeds a simpler adequate
// candidate's by more than options.heldout_tolerance (relative) is left out (vetoed).
// Candidates must be in order of complexity. Public for tests of the rule at its boundaries.
void ChooseModel(const FitOptions& options, ScreenFitResult* result);

// P(X >= chi2) for X chi-square distributed with dof degrees of freedom (the regularized upper incomplete gamma
// function Q(dof/2, chi2/2), series or continued fraction, relative error ~1e-14). NaN unless dof > 0 and
// chi2 >= 0.
double ChiSquareUpperTail(double chi2, double dof);

// The surface points of candidate `fit` at display coordinates `uv` (-1..1 edge to edge), in the frame of the camera
// of photo `photo` as fitted (x right, y down, z forward), mm: the model's surface, deviation field included, placed
// by that photo's fitted pose. `options` must be the ones the fit ran with (the deviation basis's size). For
// comparing a fitted shape with a truth in a frame free of the fit's gauge (benchmarks). Throws Error for a photo
// out of range.
std::vector<Eigen::Vector3d> FittedSurfacePointsInCamera(const Monitor& nominal, const ModelFit& fit, int photo,
                                                         const std::vector<Eigen::Vector2d>& uv,
                                                         const FitOptions& options);

// Cramer-Rao bound of the radius (mm) of the `cylinder` model for isotropic Gaussian pixel noise sigma_px
// (per coordinate) at the given true configuration: monitor (its curvature is the truth, must be non-zero),
// one camera pose (centre_from_cam) and one list of display positions per photo.
// sigma_R = sigma_px sqrt([(J^T J)^-1]_kk) / k^2, with J the Jacobian of all residuals with respect to the poses and
// k at the truth.
double RadiusCramerRaoBoundMm(const Monitor& true_monitor, const CameraModel& camera,
                              const std::vector<Pose>& centre_from_cams,
                              const std::vector<std::vector<Eigen::Vector2d>>& display_px, double sigma_px);

// The two-sided quantile of Student's t for coverage probability p (e.g. 0.95) at dof degrees of freedom
// (infinity: the normal quantile); Hill's expansion (Abramowitz & Stegun 26.7.5) from the normal quantile,
// accurate to 1e-3 for dof >= 3. Throws Error for dof < 1.
double StudentTCoverageFactor(double p, double dof);

// One row of a budget as the coverage factor sees it: its standard uncertainty for the quantity, its degrees of
// freedom (infinity for type B) and its distribution.
struct CoverageRow {
  double u = 0;
  double dof = std::numeric_limits<double>::infinity();
  RowDistribution distribution = RowDistribution::kNormal;
  // kSampled: the row's error is u times one of these, equally likely (magnitudes: the distribution is
  // symmetric). Not owned.
  const std::vector<double>* draws = nullptr;
};

// The coverage factor k of a quantity whose error is the sum of independent rows: the interval value +- k u_c,
// u_c^2 the sum of the rows' u^2, holds the truth with probability p. The normal rows pool into one normal part
// of standard uncertainty u_n (Welch-Satterthwaite dof nu, JCGM 100 G.4.1), widened to s = u_n t_p(nu) / z_p so
// that alone it gives Student's t (JCGM 100 G.3); the largest rectangular row, of half-width a = sqrt(3) u, is
// convolved with it exactly (P(|N(0, s^2) + U(-a, a)| <= c) in closed form, JCGM 101 5.1-style propagation of the
// distributions rather than the normal approximation of JCGM 100 G.6.6, which over-covers when a rectangular row
// dominates: at p = 0.95 k goes from t_p(nu) with no rectangular row to 1.645 when it is alone); further
// rectangular rows are pooled into the normal part. Throws Error for p outside (0, 1), a negative or non-finite
// u. A sampled row (the largest with draws; others join the normal part) is convolved with the normal and
// rectangular parts by averaging their distribution function over its draws: P(|u x + N + U| <= c), the mean over
// the draws x. Writes the normal part's dof to *normal_dof when given.
double CoverageFactor(double p, const std::vector<CoverageRow>& rows, double* normal_dof = nullptr);

// The coverage probability of +- 1 standard deviation of a normal distribution, erf(1 / sqrt 2): the level of the
// 68% intervals.
inline constexpr double kCoverage68 = 0.682689492137086;

// The Legendre field basis over an image of width x height px: one column per polynomial
// P_i(x') P_j(y'), i + j <= degree, x' = 2 x/(width - 1) - 1 (likewise y'), evaluated at the points.
Eigen::MatrixXd LegendreFieldBasis(const std::vector<Eigen::Vector2d>& points_px, int width, int height, int degree);

// A random-feature basis: one row per point, one column per feature (rows contiguous: the fit gathers them photo
// by photo).
using FieldBasis = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A stationary random field of unit variance as D random Fourier features (Rahimi & Recht 2007): feature m is
// sqrt(2/D) cos(w_m . p + b_m), w_m in rad/px (row m of omega), b_m in rad; N(0, 1) coefficients give the field.
// The basis is evaluated where it is needed (a photo's points at a time): the fit's candidates take 13 fields x 400
// features at every observation, 210 MB at ten photos if stored at once.
struct FieldFeatures {
  Eigen::MatrixXd omega;   // D x 2, rad/px
  Eigen::VectorXd offset;  // D, rad
  // The basis at the points: one row per point, one column per feature. Each row depends on its point only (the
  // same values whichever points are evaluated together). Evaluate reuses *out's storage when its size fits.
  void Evaluate(const std::vector<Eigen::Vector2d>& points_px, FieldBasis* out) const;
  FieldBasis At(const std::vector<Eigen::Vector2d>& points_px) const;
};

// Covariance exp(-|d|^2 / (2 L^2)) (L = length_px): w_m ~ N(0, I) / L, b_m ~ U(0, 2 pi), seeded.
FieldFeatures GaussianFieldFeatures(double length_px, int features, unsigned seed);

// A spectrum on a ring of radius 2 pi / P (P = period_px): covariance J0(2 pi |d| / P), which changes sign at
// |d| = 0.38 P; w_m = (2 pi / P)(cos t_m, sin t_m) with the directions t_m stratified over [0, pi), b_m ~ U(0, 2 pi),
// seeded.
FieldFeatures RingFieldFeatures(double period_px, int features, unsigned seed);

// The features of one lens-model-misfit component (UncertaintyBudget::FieldComponent): its family's
// (GaussianFieldFeatures at length_px, RingFieldFeatures at period length_px) with options.misfit_features
// features, seeded per family from options.systematic_field_seed as the budget's own measurement and propagation
// are, so that a propagation elsewhere (calibrate/from_screen_budget.cc) uses the same fields.
FieldFeatures MisfitComponentFeatures(const UncertaintyBudget::FieldComponent& component, const FitOptions& options);

// The component's covariance per coordinate (px^2) between two points distance_px apart: s^2 exp(-d^2 / 2 L^2)
// (kGaussian) or s^2 J0(2 pi d / P) (kRing), s^2 = variance_px2.
double MisfitComponentCovariance(const UncertaintyBudget::FieldComponent& component, double distance_px);

// The degrees of freedom of the mean square over a width x height px imager of one Gaussian field (covariance
// s^2 exp(-|d|^2 / 2 L^2), L = length_px), as an estimate of s^2: (W H)^2 / (the double integral over the
// imager of rho^2), Satterthwaite's for a quadratic form of a Gaussian vector (E = s^2, var = 2 s^4
// mean(rho^2)). A lens's stated misfit RMS is such a mean square: L = W / 5 gives 6-8 on 3:2 to 16:9 imagers;
// L -> 0 gives many, L -> oo 1.
double FieldMeanSquareDof(double length_px, int width, int height);

// A lens misfit field scaled to RMS 1 over the imager, as a calibration's stated RMS is one lens's mean square
// there (and as synth/lens_misfit.h scales each lens), drawn `count` times: per coordinate c an independent
// Gaussian field f_c (covariance exp(-|d|^2 / 2 L^2)), z_c = f_c / sqrt(mean square of f_c over the width x height
// px imager). The field is expanded in the imager's Karhunen-Loeve modes (the kernel separates in x and y: the
// products of each axis's eigenvectors on a grid of cell centres, at least 8 per length and 64 to 256, extended
// to points by Nystrom's formula; modes down to 1e-6 of the largest), so that each draw's mean square is exactly
// sum lambda g^2 of its own normal draws g. Drawn once per fit (it is the lens's), answered per candidate model
// (Respond). ok false when the imager holds more than kMaxModes modes (L below about width / 22 on 3:2, where the
// mean square has some 100 degrees of freedom or more and the scaling matters little). Deterministic in seed.
struct NormalisedField {
  static constexpr size_t kMaxModes = 800;
  bool ok = false;
  double length_px = 0;
  struct Axis {
    Eigen::VectorXd grid;     // cell centres, px
    Eigen::MatrixXd vectors;  // the kept eigenvectors (unit norm), grid x modes
    Eigen::VectorXd mu;       // their eigenvalues of the kernel matrix
  };
  Axis axis[2];
  std::vector<std::pair<long, long>> modes;  // (x mode, y mode)
  Eigen::VectorXd lambda;                    // per mode: its share of the mean square
  std::array<Eigen::MatrixXd, 2> normals;    // per coordinate: modes x count
  std::array<Eigen::RowVectorXd, 2> inverse_rms;  // per coordinate and draw: 1 / sqrt(sum lambda g^2)

  static NormalisedField Draw(double length_px, int width, int height, int count, unsigned seed);
  // Draws of linear responses: row r of weights[c] (rows x points) weights z_c at the points; draw d of row r is
  // sum_c weights[c].row(r) z_c (rows x count). gaussian_sd: each row's standard deviation for the field without
  // the scaling (E[draw^2] differs: the scaling narrows what follows the field's mean square, the mean, and
  // widens the finer structure, like Student's t).
  Eigen::MatrixXd Respond(const std::vector<Eigen::Vector2d>& points, const std::array<Eigen::MatrixXd, 2>& weights,
                          Eigen::VectorXd* gaussian_sd) const;
};

// A stated lens model misfit field (FitOptions::stated_lens_misfit_px, the sidecar's misfit, analyze --lens-misfit)
// is one: an RMS in [0, 100) px and, when the RMS is not 0, a positive finite correlation length in px.
bool IsLensMisfitField(double rms_px, double length_px);

// The pixel pitch's tolerance in percent (the commands' --pitch-tolerance) as FitOptions::pitch_tolerance_relative.
// Throws Error naming `option` outside [0, 50) percent.
double PitchToleranceFromPercent(double percent, const std::string& option);

// The intrinsics covariance written beside a camera model at calibration time (format
// curvecheck.intrinsics_covariance/1: lensmodel, intrinsics, covariance n x n, dof, ...). Throws Error naming the
// file when it cannot be read or does not match `camera` (lens model, parameter count).
// Optional "misfit": {"rms_px", "length_px"}: the lens model misfit the calibration measured (CandidateResult::
// misfit_*), which ApplyTo states as FitOptions::stated_lens_misfit_px unless a misfit is stated already.
struct IntrinsicsCovariance {
  Eigen::MatrixXd covariance;
  double dof = std::numeric_limits<double>::infinity();
  std::string source;
  double misfit_rms_px = 0, misfit_length_px = 0;  // 0: not in the file

  void ApplyTo(FitOptions* options) const;
};
IntrinsicsCovariance ReadIntrinsicsCovariance(const std::filesystem::path& path, const CameraModel& camera);
// Where the covariance of a camera model is looked for: CAM.cameramodel -> CAM.intrinsics_covariance.json.
std::filesystem::path IntrinsicsCovariancePathFor(const std::filesystem::path& camera_path);

}  // namespace curvecheck
