// The correction-error field: the smooth part of a photo's verification residuals, separated from detection
// noise (issue 15 item 1; ../shared/design/metrology.md section 2).
//
// A correction error is systematic and smooth over the screen (a misstated viewpoint, a wrong radius, a
// method's approximation); detection noise is independent from feature to feature. The residuals left by the
// verification's homography are modelled, in camera px, as
//     r_i = J_i f(d_i) + e_i,   e_i ~ N(0, sigma^2 I2) independent,
// with d_i the feature's display position, J_i = d(camera px)/d(display px) there, and f a display-px field in
// a tensor Legendre basis P_a(x) P_b(y) (a <= Du, b <= Dv over the features' bounding box). The residuals are
// already orthogonal to the homography's 8 directions (the columns of `nuisance`), so the field is fitted by
// ordinary least squares, c = A^+ r, and its covariance is the sandwich
//     Cov(c) = sigma^2 A^+ (I - P_H) A^+^T,
// P_H the projector onto the nuisance columns: what a change of the camera's pose or the plane can absorb is
// neither error nor evidence. sigma^2 = RSS / dof with dof = 2n - k - (rank A - tr(P_A P_H)), the expected
// residual sum's own count.
//
// Degree: a ladder of levels (Du = L across, Dv scaled by the features' aspect), chosen by AIC
// (AIC: 2n ln(RSS / 2n) + 2p); features whose residual about the field exceeds `outlier_sigmas` robust sigmas
// (1.4826 MAD per coordinate) are left out and the choice is made again. An error rougher than the highest
// level (at the feature spacing) cannot be told from noise: it raises sigma, and so the band, instead.
//
// The band: a simultaneous 95% bound on the estimation error over all features, the 95th percentile of
// max_i |f_hat_i - f_i| over Monte Carlo draws from Cov(c) (seeded), times the Student-t over normal ratio at
// `dof` for sigma's own uncertainty. Because an order statistic of |f_i| moves by at most the largest change
// of one |f_i|, [e - band, e + band] holds the true 95th percentile of |f| (or any other percentile) whenever
// the band holds, i.e. with probability >= 95% when the model is right. The degree is itself estimated: the
// largest change at a feature when the next level up is fitted instead is added to the band in quadrature
// (it holds the truncation bias of a level chosen too low; measured coverage in error_field_test.cc).
//
// Pixel-locking. Sub-pixel estimators are pulled toward the pixel grid: the detection error is a periodic
// function of the detected position's sub-pixel phase (peak-locking in particle image velocimetry; cornerSubPix
// and saddle fits alike), to first order
//     e_x = a_x sin(2 pi q_x) + b_x cos(2 pi q_x),   e_y = a_y sin(2 pi q_y) + b_y cos(2 pi q_y),
// with q the detected camera px (integers at pixel centres). On the default synthetic camera at quarter
// resolution this first harmonic explains 97-98% of the detection error's variance (0.047 px amplitude), and
// the error, though it looks like noise, is correlated along the board's rows and columns (the phase beats with
// the feature spacing): it moved the fitted radius by 2 of its sigmas. When `camera_px` is given, the four
// coefficients are fitted jointly with the field at the chosen level (their columns beside the field's, in
// the same least squares and sandwich covariance) and returned; the reported field, noise and band stay those
// of the field alone (see error_field.cc for why). The phases vary fast across the features (non-integer
// spacing), so the columns are nearly orthogonal to a smooth field; where they are not (a spacing near a whole
// number of pixels), the minimum-norm solution leaves the common part in the field and the coefficients'
// covariance says how little is known.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace curvecheck {

struct ErrorFieldInput {
  std::vector<Eigen::Vector2d> display_px;   // feature positions on the display
  std::vector<Eigen::Matrix2d> jacobian;     // camera px per display px at each feature (invertible)
  std::vector<Eigen::Vector2d> residual_px;  // camera px, already orthogonal to `nuisance`
  Eigen::MatrixXd nuisance;                  // 2n x k (rows 2i, 2i+1: feature i's x, y); k may be 0
  // The detected camera px of each feature: when given (same size), the pixel-locking coefficients are fitted
  // with the field (see above); empty: no pixel-locking term.
  std::vector<Eigen::Vector2d> camera_px;
};

// Pixel-locking coefficients (a_x, b_x, a_y, b_y), camera px, and the bias they predict at a detected position
// (detected - true), camera px.
struct PixelLocking {
  bool estimated = false;
  Eigen::Vector4d coefficients = Eigen::Vector4d::Zero();
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  // The detection noise once the term is removed: the scatter about the field and the term, camera px per
  // coordinate (what the screen fit, which sees corrected detections, should be compared with).
  double noise_px = 0;
  // Amplitude per coordinate, hypot(a, b), camera px.
  Eigen::Vector2d Amplitude() const;
  Eigen::Vector2d BiasAt(const Eigen::Vector2d& camera_px) const;
  // d(bias)/d(coefficients) at a detected position (2 x 4).
  static Eigen::Matrix<double, 2, 4> Basis(const Eigen::Vector2d& camera_px);
};

struct ErrorFieldOptions {
  int max_degree = 16;        // highest Du on the ladder
  double outlier_sigmas = 5;  // per coordinate, robust sigma
  // Floor of the robust sigma for the outlier test, camera px: on a very clean photo the scatter is far below the
  // detector's systematic error (pixel-locking), which would otherwise flag ordinary features as outliers.
  double outlier_floor_px = 0;
  int draws = 400;
  uint64_t seed = 20261201;
};

struct ErrorField {
  int degree_u = 0, degree_v = 0;
  int parameters = 0;      // field coefficients (2 (Du + 1)(Dv + 1))
  double dof = 0;          // residual degrees of freedom
  double noise_px = 0;     // sigma, camera px per coordinate
  std::vector<Eigen::Vector2d> value;       // f at each feature, display px
  std::vector<Eigen::Matrix2d> covariance;  // of f at each feature, display px^2
  std::vector<bool> outlier;                // left out of the fit
  double band95_display_px = 0;             // simultaneous 95% bound (see above), selection included
  double selection_display_px = 0;          // largest change at a feature from the next level up
  double rms_sigma_display_px = 0;          // RMS over features of sqrt(trace covariance)
  PixelLocking pixel_locking;               // fitted with the field when ErrorFieldInput::camera_px is given
};

// Throws Error when the sizes do not match or fewer than 4 features are given.
ErrorField EstimateErrorField(const ErrorFieldInput& input, const ErrorFieldOptions& options = {});

}  // namespace curvecheck
