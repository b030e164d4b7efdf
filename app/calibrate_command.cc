// `curvecheck calibrate (--board NxM --square-mm S | --board-from pattern.json) photos... -o cam.cameramodel`:
// detects the board in every photo (in parallel), solves every candidate lens model with mrcal, chooses the
// simplest adequate one, prints the candidate table and writes the chosen model (a mrcal .cameramodel with its
// optimization inputs) and cam.calibration.json (the report: per-photo and per-corner residuals, outliers,
// every candidate's figures, the uncertainty grid). A photo whose decoded content repeats an earlier one's is
// used once (calibrate/photos.h): a note on stderr and in cam.calibration.json names both files. The work is
// calibrate/calibrate_run.h; this file parses the options.
// `curvecheck calibrate --from-screen --monitor M --pattern pattern.json photos... -o cam.cameramodel`: calibrates
// from photos of the monitor itself (calibrate/from_screen.h): the lens jointly with the poses and the screen's
// curvature; writes the model, cam.calibration.json (with `screen`) and the intrinsics covariance.
#include "app/calibrate_command.h"

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "calibrate/calibrate_run.h"
#include "calibrate/from_screen.h"
#include "core/error.h"

namespace curvecheck::app {
namespace {

int RunCalibrate(const CalibrateRequest& a) {
  if (a.from_screen) {
    RunScreenCalibration(a, std::cout);
    return 0;
  }
  if (!a.monitor.empty() || !a.pattern.empty()) {
    throw Error(a.monitor.empty() ? "--pattern" : "--monitor", "is an option of --from-screen",
                "add --from-screen, or calibrate from a board with --board/--board-from");
  }
  RunBoardCalibration(a, std::cout, std::cerr);
  return 0;
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, std::function<int()>& run) {
  auto a = std::make_shared<CalibrateRequest>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Calibrate the camera with mrcal from chessboard photos: detect, solve the candidate lens models, "
                   "keep the simplest adequate one; writes CAM.cameramodel and CAM.calibration.json");
  cmd->add_option("photos", a->photos, "Chessboard photos (one camera, one resolution)")->required();
  cmd->add_option("-o,--output", a->output, "Output camera model (.cameramodel)")->required();
  cmd->add_option("--board", a->board, "Inner corners across x down, e.g. 9x6");
  cmd->add_option("--square-mm", a->square_mm, "Square edge in mm (with --board)");
  cmd->add_option("--board-from", a->board_from,
                  "pattern.json of a checkerboard rendered by `curvecheck render` for a FLAT monitor: the monitor "
                  "is the target, squares sized by its pixel pitch");
  cmd->add_option("--lensmodel", a->lensmodel,
                  "auto (OPENCV4, OPENCV8 and a splined model; the simplest adequate one wins) or one mrcal "
                  "LENSMODEL_... name")
      ->capture_default_str();
  cmd->add_option("--detector", a->detector, "auto | opencv | mrgingham (square boards only)")->capture_default_str();
  cmd->add_option("--search-max-px", a->search_max_px,
                  "Longest side of the reduced copy the board search runs on (0 = full size); corners are refined "
                  "at full resolution")
      ->capture_default_str();
  cmd->add_option("--threads", a->threads, "Photos detected in parallel (0 = all cores)")->capture_default_str();
  cmd->add_option("--focal-px", a->focal_px, "Focal length seed, px (0 = estimate with OpenCV)")->capture_default_str();
  cmd->add_option("--distance-mm", a->distance_mm,
                  "Distance at which uncertainty and cross-validation differences are evaluated (0 = infinity)")
      ->capture_default_str();
  cmd->add_option("--splined-nx", a->splined_nx, "Knots across of the splined candidate")->capture_default_str();
  cmd->add_flag("--no-cross-validate", a->no_cross_validate, "Skip the two-halves cross-validation (faster)");
  cmd->add_flag("--from-screen", a->from_screen,
                "Calibrate from photos of the monitor showing --pattern (no board): the lens jointly with the camera "
                "poses and the screen's curvature; seeded from --focal-px or EXIF");
  cmd->add_option("--monitor", a->monitor, "With --from-screen: the monitor preset or spec (its physical size)");
  cmd->add_option("--pattern", a->pattern, "With --from-screen: the pattern.json shown in the photos");
  cmd->add_option("--min-photos", a->min_photos, "With --from-screen: fewer photos are refused")->capture_default_str();
  cmd->add_option("--max-projection-sigma", a->max_projection_sigma,
                  fmt::format("With --from-screen: photos whose lens has a larger median projection sigma (px) where "
                              "they put the screen are refused with the positions to add (0: no limit); without it "
                              "the limit {:.3f} px is checked, and a shortfall is reported with the positions to add",
                              FromScreenOptions{}.max_projection_sigma_px));
  cmd->callback([&run, a] { run = [a] { return RunCalibrate(*a); }; });
}

}  // namespace curvecheck::app
