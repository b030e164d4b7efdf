// Two lens models of one camera compared where it matters, with their uncertainties (issue 20 part 2): mrcal's
// projection difference (mrcal.projection_diff: both models unproject the same pixels, the rotation between the two
// camera frames that best maps one set of rays onto the other is fitted over a region, and the first model's rays
// are projected by the second through it) together with the difference's covariance, propagated from both models'
// intrinsics covariances through that whole computation (the fitted rotation included: the part of an intrinsics
// error that a rotation absorbs, e.g. a principal point shift, is no difference; mrcal's projection uncertainty
// treats the frame the same way).
//
// Linear propagation: d(theta_a, theta_b) is the vector of differences at the grid points; its Jacobians G_a, G_b
// (central differences, steps of 1e-3 sigma of each intrinsic) give Cov(d) = G_a C_a G_a^T + G_b C_b G_b^T. A model
// without a covariance (a synthetic truth) adds nothing. Rays at infinity: the translation between the frames plays
// no part (mrcal's projection_diff with distance=None).
//
// Per grid point: d (2-vector, px), its 2 x 2 covariance, the worst-direction sigma (sqrt of the largest eigenvalue,
// mrcal's "worst direction") and the Mahalanobis distance m = sqrt(d^T Cov^-1 d) (chi-square with 2 degrees of
// freedom if both uncertainties are right and the models differ only by their noise).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <utility>
#include <vector>

#include "analysis/screen_fit.h"
#include "core/camera_model.h"

namespace curvecheck {

struct LensWithCovariance {
  LensWithCovariance(CameraModel m, Eigen::MatrixXd c = {}) : model(std::move(m)), covariance(std::move(c)) {}
  CameraModel model;
  Eigen::MatrixXd covariance;  // intrinsics, mrcal's order; empty = exact (no uncertainty)
  // A lens that departs from its model by a field delta (a synthetic truth: synth/lens_misfit.h): true_image_of(q)
  // = q + delta(q) maps the model's projection q to the true image, model_pixel_of inverts it. Both empty: the
  // model is the lens. Set both or neither.
  std::function<Eigen::Vector2d(const Eigen::Vector2d&)> true_image_of, model_pixel_of;
  // The lens's departure from this model that no intrinsics of the model follow (a calibration's measured lens
  // model misfit): stationary fields, independent per coordinate, one per component (Gaussian: variance s^2 per
  // coordinate and correlation length; ring: variance and period; analysis/screen_fit.h UncertaintyBudget::
  // FieldComponent). Added to the difference's covariance (cell to cell, MisfitComponentCovariance summed over the
  // components) only when the other model is exact (a truth): two calibrations of one lens see the same departure,
  // which cancels in their difference. Conservative: the part of the field the intrinsics absorbed is counted in
  // both terms.
  std::vector<UncertaintyBudget::FieldComponent> unmodelled;
};

struct ProjectionComparison {
  std::vector<Eigen::Vector2d> pixel_px;  // the grid (pixels of both imagers: they must be the same size)
  std::vector<bool> in_region;            // where the rotation is fitted and the statistics are taken
  std::vector<Eigen::Vector2d> diff_px;   // model b's projection of model a's ray (rotated) minus the pixel
  std::vector<Eigen::Matrix2d> covariance_px2;
  std::vector<double> sigma_px;           // worst direction
  std::vector<double> mahalanobis;        // NaN where the covariance is singular
  double rotation_deg = 0;                // the fitted rotation's angle
  int rank = 0;  // numerical rank of the combined covariance over the region (its independent error modes)
  // Summaries over the region.
  double median_px = 0, max_px = 0, median_sigma_px = 0, max_sigma_px = 0;
  double median_mahalanobis = 0, max_mahalanobis = 0;
};

// A grid of gx x gy pixel centres over the imager (cell centres, row-major).
std::vector<Eigen::Vector2d> ImagerGrid(int width, int height, int gx, int gy);

// Compares a with b on `grid` (pixels), the rotation fitted over and the statistics taken on the points where
// `region` is true (all when empty). Throws Error if the models' imager sizes differ or the region has fewer than
// 3 points.
ProjectionComparison CompareProjections(const LensWithCovariance& a, const LensWithCovariance& b,
                                        const std::vector<Eigen::Vector2d>& grid, const std::vector<bool>& region);

// The grid points of `grid` (cell centres of a gx x gy grid over width x height) whose cell holds at least
// `min_points` of the observed pixels: where the photos put features (the covered area, cell by cell; a bounding
// box of all detections also counts the corners of the box that no photo saw).
std::vector<bool> CoveredCells(const std::vector<Eigen::Vector2d>& observed_px, int width, int height, int gx, int gy,
                               int min_points = 1);

// The chi-square quantile with 2 degrees of freedom, -2 ln(alpha): P(chi2_2 > q) = alpha.
double ChiSquare2Quantile(double alpha);

// The decision rule for "the two models agree within their uncertainties": the largest per-point Mahalanobis
// distance over the region is at most sqrt(chi2_2 quantile at alpha / rank) (a Bonferroni bound over the rank of
// the combined covariance, its independent error modes; family-wise level alpha). Returns that bound.
double AgreementBound(const ProjectionComparison& c, double alpha = 0.05);
inline bool Agree(const ProjectionComparison& c, double alpha = 0.05) {
  return c.max_mahalanobis <= AgreementBound(c, alpha);
}

}  // namespace curvecheck
