// The capture plan (issue 20 part 1): before any photo is taken, what radius sigma and what verification
// capability a camera can reach on a monitor, from which positions, with how many photos.
//
// The prediction runs the analysis's own machinery on detections simulated at the truth: the pattern's
// features on the nominal (ideal) screen, projected through the camera model at each planned pose, each
// coordinate perturbed by the detection noise expected of a realistic camera (DetectionNoiseModel, measured
// on the realistic synthetic chain), then the screen fit (analysis/screen_fit.h, cylinder model) with its
// whole uncertainty budget (detection noise, detector systematic, lens calibration when the camera model
// carries a covariance, lens model misfit, pixel pitch) and the verification (analysis/verify.h) with its
// expanded uncertainty U. The rows that do not shrink with more photos (pixel pitch, the smooth detector bias
// and the lens, common to every photo) are in the prediction, so a target the camera cannot reach is said to
// be out of reach, with the reason.
//
// Frames: the architecture's screen frame (origin on the cylinder axis, the screen centre at (0, 0, -R));
// camera placements are given about the screen centre: distance along the direction at `yaw` about the
// vertical axis through the centre (positive yaw: the camera to the right, +x), and height along +y; the
// camera looks at the screen centre, its x axis level (up = +y).
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "analysis/screen_fit.h"
#include "core/camera_model.h"
#include "core/monitor.h"
#include "core/pose.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

// The per-coordinate detection noise (camera px) that `analyze` measures on photos of the realistic chain, as
// a function of the camera's resolving power on the display: m = camera px per display px at the features
// (the median over them; < 1 when a camera pixel sees more than one display pixel). Linear interpolation in
// log m between the rows, constant beyond the ends. Values: DefaultDetectionNoiseModel.
struct DetectionNoiseModel {
  std::vector<std::pair<double, double>> camera_px_per_display_px_to_noise_px;  // ascending in m
  // Part of that noise is the detector's pixel-locking: a bias A sin(2 pi phase + psi) per coordinate at each
  // detection's subpixel phase (analysis/screen_fit.h ResidualPixelLocking), A = this fraction of the noise,
  // psi common to the photos (a property of the detector); the rest is independent Gaussian noise, so that
  // the total RMS per coordinate is the noise (A^2/2 + g^2 = noise^2). The budget's detector-systematic row
  // measures A.
  double pixel_locking_fraction = 0;
  std::string source;  // where the rows come from (printed with the plan)

  double NoisePx(double camera_px_per_display_px) const;
  void Check(const std::string& where) const;
};
DetectionNoiseModel DefaultDetectionNoiseModel();

struct PlanOptions {
  // The radius sigma to reach (mm); 0: none (then `photos` photos, default 4, are planned).
  double target_radius_sigma_mm = 0;
  // The verification's tolerance T (display px), as analyze's --tolerance.
  double tolerance_display_px = 0.5;
  // A fixed number of photos (0: the fewest that reach the target, up to max_photos).
  int photos = 0;
  int max_photos = 12;
  // The grid of placements searched: distances from the screen centre (mm), yaws (deg; each also mirrored to
  // -yaw), heights (mm).
  std::vector<double> distances_mm = {700, 850, 1000, 1250, 1500, 2000, 2500, 3000};
  std::vector<double> yaws_deg = {0, 10, 20, 30, 40, 50};
  std::vector<double> heights_mm = {0, 150};
  // A placement is usable when every feature projects inside the imager with this margin (fraction of the
  // imager's width and height on each side; detectors need the whole board and some room around it), the
  // nearest features are at least min_feature_spacing_camera_px apart in the image (a square of fewer px is
  // not reliably detected: the sweep's not_found points), and no feature is seen more obliquely than
  // max_obliquity_deg from its surface normal (beyond 60 deg a board's corners are foreshortened by half and
  // the display's viewing-angle fall-off dims them).
  double imager_margin = 0.04;
  double min_feature_spacing_camera_px = 12;
  double max_obliquity_deg = 60;
  // The lens model misfit assumed of the camera (RMS px per coordinate, as a fraction of the imager's width):
  // a smooth field common to every photo added to the simulated detections. 1.7e-5: 0.1 px on a 6000 px
  // imager, the realistic synthetic lens (imaging preset ilc24) and below mrcal's tour's 0.2-0.4 px at 6000
  // px for a real calibration. 0: the camera model taken as exact.
  double lens_misfit_relative = 1.7e-5;
  DetectionNoiseModel noise = DefaultDetectionNoiseModel();
  // Seeds of the simulated detections; the prediction is the RMS over them (the budget's measured rows vary a
  // little with the noise draw).
  int seeds = 2;
  unsigned seed = 1;
  // The fit's options (the lens covariance, the pitch tolerance, ...); models and held-out folds are set by
  // the planner (the cylinder, the model of a nominal curved monitor; no folds).
  FitOptions fit;

  void Check(const std::string& where) const;
};

// One camera placement and what it sees.
struct PlanPlacement {
  double distance_mm = 0, yaw_deg = 0, height_mm = 0;
  Eigen::Vector3d position_in_screen_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d look_at_in_screen_mm = Eigen::Vector3d::Zero();
  Pose screen_from_cam;
  bool usable = false;
  std::string why_not;                   // when not usable
  int features = 0;                      // in view
  double feature_spacing_camera_px = 0;  // the smallest nearest-neighbour distance in the image
  double camera_px_per_display_px = 0;   // median over the features
  double max_obliquity_deg = 0;
  double noise_px = 0;  // DetectionNoiseModel at camera_px_per_display_px
  // The Cramer-Rao bound of the radius from this photo alone at noise_px (the detection noise row only), mm.
  double radius_crb_mm = 0;
};

struct PlanBudgetRow {
  std::string name;
  double radius_mm = 0;
};

struct CapturePlan {
  std::vector<PlanPlacement> grid;       // every placement searched, in grid order
  std::vector<PlanPlacement> positions;  // the recommended ones, in the order to shoot them
  // The predicted radius sigma of `analyze` on photos from `positions` (the budget's combined u(R)), and its
  // rows.
  double predicted_radius_sigma_mm = 0;
  std::vector<PlanBudgetRow> budget;
  // The part that no number of photos from these placements removes: the pixel pitch row (and the lens
  // calibration row, common to every photo), mm.
  double radius_sigma_floor_mm = 0;
  bool target_reached = false;
  std::string target_note;  // how the count was chosen, or why the target is out of reach
  // Predicted sigma (mm) against the number of photos: (count, sigma) for every count predicted (1 .. the
  // recommended count when searching for the target; the given count alone with PlanOptions::photos); NaN
  // where the simulated fit gave no radius.
  std::vector<std::pair<int, double>> sigma_by_photos_mm;
  // The verification from the pattern's viewpoint (the eye point): the expanded uncertainty U (k = 2) in
  // display px, the tolerance ratio T / U, the predicted verdict of a correct rendering (e + U <= T: pass),
  // and whether the camera there is usable at all.
  bool verification_predicted = false;
  std::string verification_note;
  PlanPlacement verification_placement;
  double predicted_verification_u_display_px = 0;
  double predicted_verification_e_display_px = 0;
  double verification_tolerance_ratio = 0;
  bool verification_conclusive = false;
  std::vector<std::string> assumptions;
};

// The placement at (distance, yaw, height) about the screen centre (see the frames above), evaluated against
// the camera, the features and the options. Throws Error for a non-positive distance.
PlanPlacement EvaluatePlacement(const Monitor& monitor, const CameraModel& camera, const PatternFile& pattern,
                                double distance_mm, double yaw_deg, double height_mm,
                                const PlanOptions& options);

// The predicted budget of the screen fit on detections simulated from `placements` (see the header comment):
// the RMS over options.seeds of the cylinder candidate's combined radius sigma and of its rows. Throws Error
// when the fit gives no radius (a flat monitor, or placements that cannot measure it).
std::pair<double, std::vector<PlanBudgetRow>> PredictRadiusSigma(const Monitor& monitor,
                                                                 const CameraModel& camera,
                                                                 const PatternFile& pattern,
                                                                 const std::vector<PlanPlacement>& placements,
                                                                 const PlanOptions& options);

// The whole plan: every placement of the grid, the recommended set and count, the predicted radius sigma and
// the verification capability. Throws Error for invalid options, a flat monitor (no radius to measure), or
// when no placement of the grid is usable (the error says which constraint failed most).
CapturePlan PlanCapture(const Monitor& monitor, const CameraModel& camera, const PatternFile& pattern,
                        const PlanOptions& options);

// plan.json (format curvecheck.plan/1).
nlohmann::json PlanJson(const CapturePlan& plan, const Monitor& monitor, const CameraModel& camera,
                        const PlanOptions& options, const std::string& command_line);

// The printed table: the recommended placements, the prediction and its budget, the verification capability.
std::string PlanText(const CapturePlan& plan, const PlanOptions& options);

// The gnuplot script of the chart (two panels): the single-photo radius sigma (Cramer-Rao at the expected
// noise) against the distance, one line per yaw, and against the yaw, coloured by distance (height 0),
// reading `data_file` (columns: distance_mm yaw_deg sigma_mm, one block per yaw >= 0, NaN where not usable):
// PlanChartData's text.
std::string PlanChartScript(const CapturePlan& plan, const std::string& data_file);
std::string PlanChartData(const CapturePlan& plan);

}  // namespace curvecheck
