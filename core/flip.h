// LDR FLIP, the perceptual difference between two images shown alternately (Andersson, Nilsson,
// Akenine-Moeller, Oskarsson, Astrom, Fairchild 2020, "FLIP: A Difference Evaluator for Alternating Images",
// HPG 2020), written from the paper's equations. The thesis behind curvecheck judges the correction methods by
// their mean FLIP against a reference image at the viewer's pixels per degree
// (../shared/seeds/000_0a6434fbdad225dc.txt 3.3, 5.2-5.5).
//
// Colour pipeline: sRGB -> linear RGB -> YyCxCz (opponent space, linear in XYZ); each channel filtered with its
// spatial contrast sensitivity function, a sum of Gaussians whose spatial form is
//   S(x) = a1 sqrt(pi/b1) exp(-pi^2 x^2/b1) + a2 sqrt(pi/b2) exp(-pi^2 x^2/b2),  x in degrees,
// (achromatic a1 = 1, b1 = 0.0047; red-green a1 = 1, b1 = 0.0053; blue-yellow a1 = 34.1, b1 = 0.04, a2 = 13.5,
// b2 = 0.025), sampled at 1/ppd deg over a radius of ceil(3 sqrt(max b/(2 pi^2)) ppd) px and normalised to sum
// 1; back to linear RGB clamped to [0, 1]; CIELAB with the Hunt adjustment (a, b scaled by L/100); the HyAB
// distance |dL| + ||(da, db)||; raised to q_c = 0.7 and mapped to [0, 1] piecewise linearly so that p_c = 0.4
// of the largest distance (Hunt-adjusted green against blue, raised to q_c) lands at p_t = 0.95.
// Feature pipeline, on the luminance Y/Yn of the unfiltered image: edges (first derivative of a Gaussian) and
// points (second derivative), sigma = 0.5 * 0.082 deg * ppd, radius ceil(3 sigma), positive weights normalised to
// sum 1 and negative ones to -1; the feature difference dF = (max(| |e_ref| - |e_test| |, | |p_ref| - |p_test| |)
// / sqrt 2)^q_f with q_f = 0.5. Per pixel: FLIP = dE_c^(1 - dF), 0 (identical) .. 1.
//
// Borders are replicated (every filter sees the nearest edge pixel beyond the image). The sRGB <-> XYZ matrix is
// derived from the sRGB primaries and the D65 white point (IEC 61966-2-1).
#pragma once

#include <opencv2/core.hpp>

namespace curvecheck {

// The paper's constants.
struct FlipConstants {
  static constexpr double kQc = 0.7, kPc = 0.4, kPt = 0.95, kQf = 0.5;
  static constexpr double kEdgeWidthDeg = 0.082;  // peak-to-trough of the human edge detector: 2 sigma
};

struct FlipResult {
  cv::Mat error;     // CV_32FC1, per-pixel FLIP in [0, 1], the images' size
  double mean = 0;   // the mean over all pixels: the figure the thesis reports
  double max = 0;
};

// FLIP against one reference, with the reference's half of the work (filtered colours, feature responses) done
// once: for benches that compare many renderings with the same reference. Same inputs and errors as ComputeFlip.
class FlipEvaluator {
 public:
  FlipEvaluator(const cv::Mat& reference, double pixels_per_degree);
  FlipResult Compare(const cv::Mat& test) const;

 private:
  int type_ = 0;
  cv::Size size_;
  double ppd_ = 0;
  cv::Mat lab_[3], edges_, points_;  // CV_32FC1: Hunt-adjusted L, a, b of the filtered image; feature magnitudes
};

// FLIP of `test` against `reference` viewed at `pixels_per_degree` (display pixels per degree of visual angle;
// FlipPixelsPerDegree). Images: CV_8UC1 (grey) or CV_8UC3 (BGR, OpenCV's order) code values, or CV_32FC1 /
// CV_32FC3 in [0, 1], all read as sRGB-encoded; both of the same size and type. Throws Error for empty, mismatched
// or unsupported images, or a pixels per degree that is not positive and finite.
FlipResult ComputeFlip(const cv::Mat& reference, const cv::Mat& test, double pixels_per_degree);

// The pixels per degree FLIP's authors give for a flat display viewed head-on (the density at the nearest
// point, small-angle form): distance_mm * pi/180 / pixel_pitch_mm.
double FlipPixelsPerDegree(double distance_mm, double pixel_pitch_mm);

}  // namespace curvecheck
