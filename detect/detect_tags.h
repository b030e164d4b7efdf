// AprilTag 3 (tag36h11) detection and the full-resolution refinement of its corners (internal to
// detect/detect.cc; detect.h states the method).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <utility>
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
  // How far the outer edges' 50% crossings sat inside the tag at its refinement's last pass, px (a tone curve's
  // shift, RefineTagCorners); NaN = not measured (too few white data cells beside the border, cells under 4 px or
  // under 2.5 edge widths, not refined).
  double border_shift_px = std::nan("");
  double smoothing_px = 0;  // the refinement's smoothing sigma (the caller's, at most a sixth of the tag's cell)
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
// tag is too small (edge < 16 px) to have a clean border profile. gamma != 1: the code values are first taken
// to light, (code / full scale)^gamma (the photo's tone curve, MeasureTagTone). sigma_px > 0: the tag's
// neighbourhood is then smoothed by a Gaussian of that sigma, at most a sixth of the tag's cell (suppresses the
// display's pixel grid; a symmetric blur does not move a straight edge in light, but does in code values under a
// tone curve, and does once it joins the border's two edges and the data cells beyond). The second pass
// also measures border_shift_px (BorderShiftPx in detect_tags.cc): how far the outer 50% crossings sit inside
// the tag. In code values a blurred edge's 50% crossing is where the light is 50% only if the photo is linear;
// under sRGB it is where the light is 21%, a fraction of the blur into the dark. The border's inner edge beside
// a white data cell crosses into the dark as well, outwards, so the border measures a cell less twice the
// shift; measured from the profiles beside white data cells with a white cell beyond them (at least 8, cells of
// 4 px or more and 2.5 times the edges' 10-90% width: a wider blur joins the border's edges to the cells beyond),
// the median of (cell - border width) / 2, the cell's width by the homography of the current corners.
bool RefineTagCorners(const cv::Mat& image, DetectedTag& tag, double sigma_px, double gamma = 1);

// The photo's tone curve as seen by its tags: up to 24 tags refined without smoothing with their code values taken
// to light by (code / full scale)^gamma, gamma = 1, 1.5, 2, 2.5, 3 in turn, until the median border shift is no
// longer positive; gamma where it is zero (linear between the ladder's steps). 1 where the shift at 1 is not
// positive (a linear photo); the ladder's last step where it stays positive; NaN where fewer than 3 tags measure
// the shift. A power law stands in for the curve (sRGB is close to 2.2): what matters is the edge's light profile
// being symmetric about the edge, which the shift's zero says.
struct TagTone {
  double gamma = std::nan("");
  double shift_px = std::nan("");                   // the median shift at gamma = 1 (the code values as they are)
  int tags = 0;                                     // tags that measured it
  std::vector<std::pair<double, double>> ladder;  // (gamma, median shift px)
};
TagTone MeasureTagTone(const cv::Mat& image, const std::vector<DetectedTag>& tags);

// The part of `image` inside `roi` (clipped to the image) as CV_32F, smoothed by a Gaussian of sigma_px if > 0
// (the border of the patch is filled by reflection; keep 3 sigma of margin around what is measured).
// gamma != 1: the code values are first taken to light, (code / full scale)^gamma, full scale 255 (CV_8U), 65535
// (CV_16U) or 1, and kept on that scale.
cv::Mat SmoothedPatch(const cv::Mat& image, cv::Rect roi, double sigma_px, cv::Point* origin, double gamma = 1);

// Bilinear sample of a CV_8U, CV_16U or CV_32F image at (x, y) (pixel centres at integers); NaN outside.
double SampleBilinear(const cv::Mat& image, double x, double y);

}  // namespace curvecheck::detect_internal
