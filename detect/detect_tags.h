// AprilTag 3 (tag36h11) detection and the full-resolution refinement of its corners (internal to
// detect/detect.cc; detect.h states the method).
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <vector>

namespace curvecheck::detect_internal {

struct DetectedTag {
  int id = 0;
  int hamming = 0;
  double decision_margin = 0;
  // Outer corners of the black border in AprilTag's order, image coordinates with pixel centres at integers
  // (AprilTag's own corners - 0.5 px until refined).
  std::array<Eigen::Vector2d, 4> px;
  double edge_rms_px = -1;  // RMS of the edge points about the fitted edge curves; -1 = not refined
};

// Runs the detector on an 8-bit photo. decimate: the photo is shrunk by this integer factor with area averaging
// (a low-pass filter; AprilTag's own quad_decimate samples single pixels, which aliases the display's pixel grid
// when the camera resolves it) and smoothed by a Gaussian of 0.8 px before the detector sees it; the corners are
// mapped back to full resolution. max_hamming: bits corrected; threads: 0 = all.
std::vector<DetectedTag> RunAprilTag(const cv::Mat& gray8, int decimate, int max_hamming, int threads);

// Refines the corners of one tag on `image` (CV_8U or CV_16U): locates its four outer border edges along their
// normals (50% crossing of the local black and white levels) at ~1 px steps, fits each with a quadratic in
// the edge's frame (robustly: points beyond 3 sigma dropped), and intersects adjacent curves; two passes.
// Returns false (tag unchanged) if an edge has too few usable points (e.g. cut by the image border) or the
// tag is too small (edge < 16 px) to have a clean border profile. sigma_px > 0: the tag's neighbourhood is first
// smoothed by a Gaussian of that sigma (suppresses the display's pixel grid; a symmetric blur does not move a
// straight edge).
bool RefineTagCorners(const cv::Mat& image, DetectedTag& tag, double sigma_px);

// The part of `image` inside `roi` (clipped to the image) as CV_32F, smoothed by a Gaussian of sigma_px if > 0
// (the border of the patch is filled by reflection; keep 3 sigma of margin around what is measured).
cv::Mat SmoothedPatch(const cv::Mat& image, cv::Rect roi, double sigma_px, cv::Point* origin);

// Bilinear sample of a CV_8U, CV_16U or CV_32F image at (x, y) (pixel centres at integers); NaN outside.
double SampleBilinear(const cv::Mat& image, double x, double y);

}  // namespace curvecheck::detect_internal
