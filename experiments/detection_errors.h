// Errors of detections against their true image positions (synthetic truth), and the smooth part of those
// errors: what a bench measures of the detector's bias where the budget can only state it (the detector-systematic
// row's FitOptions::smooth_bias_px, type B). Shared by bench calibrate --flat-vs-board and bench validity.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <vector>

namespace curvecheck::experiments {

// Per coordinate, px. NaN (also as constructed) where there were too few points (fewer than 20 in all, or in every photo).
struct DetectionErrors {
  int points = 0;
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double rms_px = kNaN;
  Eigen::Vector2d mean_px = Eigen::Vector2d::Constant(kNaN);
  // The least-squares field of Legendre polynomials of total degree <= 3 over the image (the family the budget's
  // smooth-bias row draws from, analysis LegendreFieldBasis), one per coordinate, fitted to all the errors: its
  // RMS at the points. Independent noise of RMS s leaks into it by about s sqrt(10 / n); and a pixel-locking
  // signature that beats slowly across the image (a regular grid seen frontally puts its features at nearly one
  // phase) is in it too: no fit can tell the two apart there.
  double smooth_rms_px = kNaN;
  // The smooth part less what independent errors of the rest's variance would leak into it (its expected square
  // s^2 k / n, k = 10 functions, s^2 the variance about the field over n - k): an estimate of the smooth bias
  // itself; 0 when the smooth part is no larger than that leak.
  double smooth_beyond_noise_px = kNaN;
  // The same with a degree-2 field fitted per photo (photos with at least 20 points).
  double per_photo_smooth_rms_px = kNaN;
  // What a periodic signature of the true position t leaves of the errors (RMS about least squares per
  // coordinate c, a constant included): the budget's model (sin, cos of 2 pi t_c and pi t_c: periods of 1 px and
  // of a colour filter array's 2 px, each coordinate's bias a function of its own phase), and that model plus the
  // 2 x 2 cell's other terms (sin, cos of pi t of the other coordinate and the four products of sin, cos pi t_x
  // with sin, cos pi t_y: a Bayer cell makes each coordinate's bias a function of both phases).
  double signature_remainder_px = kNaN, cell_signature_remainder_px = kNaN;
};

// at: where each error was detected (image px); err: detected - true; photo: the photo of each error.
DetectionErrors DetectionErrorsOf(const std::vector<Eigen::Vector2d>& at, const std::vector<Eigen::Vector2d>& err,
                                  const std::vector<int>& photo, int width, int height);

}  // namespace curvecheck::experiments
