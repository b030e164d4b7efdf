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

}  // namespace curvecheck
