// What `curvecheck calibrate` does once its options are parsed (app/calibrate_command.cc): the checks of its
// inputs and outputs, the calibration, the printed summary and the written set (CAM.cameramodel,
// CAM.calibration.json, CAM.intrinsics_covariance.json). Errors name the option at fault.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace curvecheck {

struct CalibrateRequest {
  std::string board, board_from, output, lensmodel = "auto", detector = "auto";
  double square_mm = 0, focal_px = 0, distance_mm = 1000;
  int splined_nx = 16, threads = 0, search_max_px = 1600;
  bool no_cross_validate = false;
  std::vector<std::string> photos;
  // --from-screen
  bool from_screen = false;
  std::string monitor, pattern;
  int min_photos = 6;
  // --max-projection-sigma: given (>= 0), photos whose lens is less precise are refused with the positions to add
  // (0: no limit); not given (< 0), the default limit is checked and a shortfall is reported with the positions to
  // add, the calibration still written (FromScreenOptions::refuse_imprecise).
  double max_projection_sigma = -1;
};

// From chessboard photos (calibrate.h): detection in parallel, every candidate lens model, the simplest adequate
// one written. A photo whose content repeats an earlier one's is used once: a note on `err` names both files.
void RunBoardCalibration(const CalibrateRequest& request, std::ostream& out, std::ostream& err);

// --from-screen (from_screen.h, library curvecheck_calibrate_screen): the lens jointly with the poses and the
// screen's curvature from photos of the monitor showing request.pattern.
void RunScreenCalibration(const CalibrateRequest& request, std::ostream& out);

// Shared by the two: the files written beside -o (which must end in .cameramodel; Error otherwise) ...
struct CalibrationFiles {
  std::filesystem::path model, report, covariance;  // X.cameramodel, X.calibration.json, X.intrinsics_covariance.json
};
CalibrationFiles CalibrationOutputs(const std::string& output);
// ... and the photos (each a file; with refuse_output_photo, none the model), checked with `target` (a
// pattern.json; "" for none) against the outputs, which must be writable: before the work.
std::vector<std::filesystem::path> CheckCalibrationFiles(const std::vector<std::string>& photos,
                                                         const CalibrationFiles& files, const std::string& target,
                                                         bool refuse_output_photo);

}  // namespace curvecheck
