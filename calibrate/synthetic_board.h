// Synthetic calibration sets with known truth: a FLAT monitor showing a checkerboard drawn on the CPU at the
// monitor's resolution (square size = whole display pixels x pixel pitch), photographed by the synthetic camera
// (capture/synthetic_camera.h) through a known mrcal lens from a choreography of poses: distances from
// close-ups (the board filling most of the frame) to far, tilts up to `max_tilt_deg`, rolls, and the board
// pushed toward every region of the imager in turn so that the corners of the image are covered. The truth of
// every corner is its analytic point projected by the true lens (TruthJson). Used by the tests and the bench.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "calibrate/board.h"
#include "calibrate/calibrate.h"
#include "calibrate/detect.h"
#include "core/camera_model.h"
#include "core/monitor.h"

namespace curvecheck {

struct SyntheticBoardOptions {
  CameraModel camera;          // the true lens (any mrcal model)
  int views = 24;
  int corners_x = 10, corners_y = 7;
  int square_display_px = 48;  // square edge on the display, px
  double pixel_pitch_mm = 0.25;
  double max_tilt_deg = 45;    // angle between the camera's view of the board and the board's normal
  double max_roll_deg = 20;
  // Board size (with its outer squares) as a fraction of the image size (the tighter of width and height) at the
  // closest and farthest views.
  double fill_near = 0.85, fill_far = 0.4;
  double blur_px = 0.8;        // Gaussian optics blur, camera px
  bool noise = true;           // Poisson-Gaussian sensor noise (capture's Sensor defaults)
  int supersample = 3;
  uint64_t seed = 1;
  void Check() const;
};

struct SyntheticBoardView {
  cv::Mat photo;                            // 8-bit gray, the camera's imager size
  std::vector<Eigen::Vector2d> corners_px;  // true image position of each corner, row-major
  Eigen::Vector3d camera_position_in_screen;
  Eigen::Matrix3d screen_from_cam;
  double tilt_deg = 0;
};

struct SyntheticBoardSet {
  BoardSpec board;
  Monitor monitor;
  std::vector<Eigen::Vector3d> corners_in_screen;  // the corners' true points, row-major (as corners_px)
  std::vector<SyntheticBoardView> views;
};

// Renders the set (RenderSyntheticPhoto on all cores, one photo after the other). Every view keeps the whole
// board and half a square of its white surround inside the image (poses are redrawn until they do).
SyntheticBoardSet MakeSyntheticBoardSet(const SyntheticBoardOptions& options);

// Known lenses for the synthetic sets (640x480, both LENSMODEL_OPENCV8):
// - StrongOpencv8Lens: f = 520 px with a strong barrel whose k3 and rational terms matter (the corners are 55 deg
//   off axis). The best radial f, k1, k2 polynomial (OPENCV4's radial part) misses it by 1.06 px RMS over the
//   imager and 12 px in the corners, so OPENCV4 cannot absorb it.
// - WideLens: f = 322 px with the rational barrel r_d = r (1 + 0.05 r^2) / (1 + 0.2 r^2) (monotonic for every r):
//   100 deg across, 120 deg on the diagonal, the edge pulled in by 17%; the best k1, k2 polynomial misses it by
//   0.22 px RMS over the imager, 2.3 px in the corners.
CameraModel StrongOpencv8Lens();
CameraModel WideLens();

// A calibrated model against the true lens of a synthetic set, on the candidate's uncertainty grid (cell centres
// over the whole imager): each grid pixel's true ray, at distance_mm (0: at infinity), is moved into the
// recovered camera frame and projected by the recovered model. The two camera frames are related through the
// boards (mrcal's uncertainty is that of a point fixed relative to the observed boards, so the small rotation that
// a calibration trades against its principal point is not part of it): recovered_from_true is the rigid motion
// that best maps every corner's true position in the true camera frame onto its position in the recovered frame
// (the solved board poses), least squares (Kabsch). `detections` are those given to Calibrate (in order); each
// detected corner is matched to its nearest true corner (the detector may start the grid at any corner).
struct TruthComparison {
  double rms_px = 0;        // |recovered - truth| RMS over the whole grid
  double rms_sigma_px = 0;  // reported uncertainty (worst direction) RMS over the grid points that have one
  double worst_ratio = 0;   // max |diff| / sigma
  int within_3sigma = 0;    // grid points with |diff| <= 3 sigma
  int points = 0;           // grid points with a reported uncertainty
  int no_sigma = 0;         // grid points where mrcal reports none (its unprojection failed); counted, not hidden
  // The same over the grid points where the reported sigma is below `confident_sigma_px`: where the calibration
  // claims to know the lens (elsewhere it extrapolates beyond its data, and says so).
  double confident_sigma_px = 0.1;
  double confident_rms_px = 0;
  int confident_points = 0;
  // The same over the grid points near observed corners (UncertaintyGrid::observed: where the data is; a
  // property of the photos, the same for every lens model).
  double observed_rms_px = 0;
  int observed_points = 0;
  double rotation_deg = 0;  // recovered_from_true
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};
TruthComparison CompareWithTruth(const CameraModel& truth, const SyntheticBoardSet& set,
                                 const std::vector<Detection>& detections, const CalibrationResult& r,
                                 const CandidateResult& candidate, double distance_mm);

}  // namespace curvecheck
