// A calibration against the truth of a synthetic set (synth/synthetic_board.h): how far the recovered lens is
// from the true one over the imager, and whether the reported uncertainty covers it. Used by the calibration
// tests and `bench calibrate`; not part of calibrating real photos.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "calibrate/calibrate.h"
#include "core/camera_model.h"
#include "detect/chessboard.h"
#include "synth/synthetic_board.h"

namespace curvecheck {

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
                                 const std::vector<ChessboardDetection>& detections, const CalibrationResult& r,
                                 const CandidateResult& candidate, double distance_mm);

}  // namespace curvecheck
