// Synthetic calibration sets with known truth: a FLAT monitor showing a checkerboard drawn on the CPU at the
// monitor's resolution (square size = whole display pixels x pixel pitch), photographed by the synthetic camera
// (synth/synthetic_camera.h) through a known mrcal lens from a choreography of poses: distances from
// close-ups (the board filling most of the frame) to far, tilts up to `max_tilt_deg`, rolls, and the board
// pushed toward every region of the imager in turn so that the corners of the image are covered. The truth of
// every corner is its analytic point projected by the true lens (TruthJson). Used by the tests and the bench.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "pattern/board.h"
#include "core/camera_model.h"
#include "core/monitor.h"
#include "core/pose.h"
#include "synth/scene.h"

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
  // The imaging chain (synth/scene.h): the clean monochrome chain by default (blur_px and noise above act); a
  // realistic preset's chain (its lens misfit, with its lens_seed) photographs the board as it would the monitor.
  Imaging imaging;
  uint64_t seed = 1;
  void Check() const;
};

struct SyntheticBoardView {
  cv::Mat photo;                            // 8-bit gray, the camera's imager size
  std::vector<Eigen::Vector2d> corners_px;  // true image position of each corner, row-major
  Pose screen_from_cam;  // the camera in the screen frame (translation: its centre, mm)
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

}  // namespace curvecheck
