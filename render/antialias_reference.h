// Anti-aliasing accuracy of a rendering without any detector (issue 3 item 5, second half): a high-precision
// CPU reference of small display crops around the features, and the sub-pixel shift that best aligns the
// rendered crop with it (Lucas-Kanade), which is the feature's placement bias.
//
// Reference: each display pixel (i, j) shows the mean, over its square [i - 0.5, i + 0.5] x [j - 0.5, j +
// 0.5] of display coordinates, of the pattern's cell function seen through the exact mapping
// (PatternFromDisplayPx, double precision), in linear light: black 0, white 1, surround (surround_code /
// 255)^gamma, off the plane the surround. Code value = 255 linear^(1/gamma) as a float (not quantized), for
// RenderOptions::display_gamma.
//
// The mean is taken by dense supersampling with area samples: the crop (plus a margin) is cut into strata of
// 1/n x 1/n px (n = samples_per_axis); the exact mapping is evaluated at every stratum corner, and each
// stratum's share of white, black and surround is the exact area of its quadrilateral image on the plane
// within each cell (polygon clipping), not a point sample. Point samples would leave an error of up to 1/(2n)
// of the edge contrast per pixel (1.5e-2 for n = 32) along edges parallel to the sample rows, which is just
// the orientation the patterns have; area samples leave only the curvature of the mapping across one stratum
// and the variation of its area scale within it. Measured (antialias_reference_test.cc, n = 32 against
// n = 64 on the 49" 1000R from an off-axis viewpoint): code values agree to 5.4e-4, shifts to 1e-7 px.
//
// A pixel square at any position is integrated from the strata with an integral image (partial strata by
// area, as if each stratum were uniform), so that the reference can be evaluated at sub-pixel shifts without
// resampling an image; at shifts that are not multiples of 1/n this differs from a reference rendered at that
// shift by at most 1.5e-3 code (measured at 0.3, -0.2 px).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/monitor.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {

// The stratified reference of one crop. Value type; build with RenderReferenceCrop.
struct ReferenceCrop {
  std::string feature_id;
  Eigen::Vector2d feature_px = Eigen::Vector2d::Zero();  // exact display position of the feature
  // The crop: display pixels x0 .. x0 + size - 1 across and y0 .. y0 + size - 1 down.
  int x0 = 0, y0 = 0, size = 0;
  int samples_per_axis = 0;  // n: strata per pixel and axis
  // The pattern as the crop shows it is moved by this much on the display (0 for the reference proper;
  // tests render shifted references to check the estimator).
  Eigen::Vector2d pattern_shift_px = Eigen::Vector2d::Zero();
  // Stratum grid: stratum (p, q) covers display [origin.x + p/n, origin.x + (p+1)/n] x [origin.y + q/n, ...].
  // It covers the crop's pixel squares grown by margin_px on every side.
  double margin_px = 0;
  Eigen::Vector2d origin_px = Eigen::Vector2d::Zero();
  int strata_w = 0, strata_h = 0;
  // Integral images, (strata_w + 1) x (strata_h + 1) row-major: sums of the white share and of the surround
  // share of the strata above and left of each grid corner (a stratum's shares add up to 1 with black).
  std::vector<double> white_integral, surround_integral;

  // Mean linear value over the 1 x 1 px square centred at display coordinates `centre_px` (anywhere within
  // the margin: |centre - a crop pixel centre| <= margin_px in both axes). Throws Error outside.
  double LinearMean(const Eigen::Vector2d& centre_px, double surround_linear) const;
};

// Renders the reference of a size x size crop around `feature` (which must have a display position): pixels
// floor(x) - size/2 + 1 .. floor(x) + size/2 (the feature within half a pixel of the crop's centre), with
// samples_per_axis^2 area samples per pixel and strata margin_px beyond the crop (for shifted evaluation
// and gradients). pattern_shift_px moves the pattern on the display (the mapping is evaluated at display
// coordinates minus the shift). Throws Error for invalid arguments.
ReferenceCrop RenderReferenceCrop(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                                  const Pattern& pattern, const Feature& feature, int crop_px = 16,
                                  int samples_per_axis = 32, double margin_px = 2,
                                  const Eigen::Vector2d& pattern_shift_px = Eigen::Vector2d::Zero());

// References of every visible feature of the pattern whose crop lies inside the display, in the pattern's
// feature order. Runs on all cores.
std::vector<ReferenceCrop> RenderReferenceCrops(const Monitor& monitor,
                                                const Eigen::Vector3d& viewpoint_in_screen,
                                                const Pattern& pattern, int crop_px = 16,
                                                int samples_per_axis = 32);

// Code values (0..255 as floats, not quantized) of the crop's pixels, row-major size x size, for the display
// gamma and surround of `options`, with the content moved by shift_px on the display.
std::vector<float> ReferenceCodes(const ReferenceCrop& crop, const RenderOptions& options,
                                  const Eigen::Vector2d& shift_px = Eigen::Vector2d::Zero());

struct FeatureBias {
  std::string id;
  Eigen::Vector2d display_px = Eigen::Vector2d::Zero();  // exact position of the feature
  // Placement bias: where the rendered crop shows the feature minus where the reference shows it (display px;
  // +x right, +y down). NaN if the estimate failed (no texture in the crop, or no convergence within the
  // reference's margin).
  Eigen::Vector2d shift_px = Eigen::Vector2d::Zero();
  double rms_code = 0;  // RMS of rendered - reference code values over the crop after alignment
  int iterations = 0;   // Lucas-Kanade iterations used
};

// The shift d that best aligns a rendered crop (row-major size x size code values of the crop's pixels) with
// the reference: Lucas-Kanade least squares, minimizing sum (I_rendered(x) - I_ref(x - d))^2 over the crop,
// linearized as I_ref(x - d - delta) ~ I_ref(x - d) - grad I_ref(x - d) . delta and iterated (Gauss-Newton).
// The reference is re-evaluated exactly at every shift (no image resampling) and its gradient is a central
// difference with a step of one stratum (1/n px), so for a rendered crop that is the reference moved by d the
// fixed point is d itself. Each step is shortened (halved) until the cost does not rise, and lengthened
// (doubled) while it falls: the code values are not smooth in d where an edge enters a black pixel
// (linear^(1/gamma) has an infinite slope at 0). Stops when a step moves less than 1e-6 px or no step lowers
// the cost; NaN after 100 iterations, when the crop has no texture in some direction, or when d would leave
// the reference's margin.
FeatureBias EstimatePlacementBias(const ReferenceCrop& crop, const RenderOptions& options,
                                  const std::vector<float>& rendered_codes);

// The bias of every reference crop in a rendered display image (of the monitor's size).
std::vector<FeatureBias> MeasurePlacementBias(const std::vector<ReferenceCrop>& crops,
                                              const RenderOptions& options, const GrayImage& rendered);

// RenderReferenceCrops + MeasurePlacementBias: every visible feature whose crop lies inside the display.
std::vector<FeatureBias> MeasurePlacementBias(const Monitor& monitor,
                                              const Eigen::Vector3d& viewpoint_in_screen,
                                              const Pattern& pattern, const RenderOptions& options,
                                              const GrayImage& rendered, int crop_px = 16,
                                              int samples_per_axis = 32);

struct PlacementBiasSummary {
  int features = 0;                                         // with a finite shift
  int failed = 0;                                           // with a NaN shift
  Eigen::Vector2d mean_shift_px = Eigen::Vector2d::Zero();  // the systematic bias
  double max_shift_px = 0;                                  // largest |shift| (Euclidean)
  double rms_shift_px = 0;                                  // RMS of |shift|
  double rms_code = 0;                                      // RMS of the per-feature rms_code
};
PlacementBiasSummary SummarizePlacementBias(const std::vector<FeatureBias>& biases);

}  // namespace curvecheck
