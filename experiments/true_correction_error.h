// The true correction error of a rendered pattern as a synthetic scene's camera sees it: the truth that the
// verification's verdict (analysis/verify.h) is judged against in `bench verdict`.
//
// Computed from the synthetic camera's geometry only (metrology.md section 4: the truth never goes through the
// analysis's code path): each feature is shown at its display position p (pattern.json's, the rendering's), the
// true monitor puts that pixel at X = TrueSurfacePointInScreen(p), the camera sees it at the normalized image
// point n(p) = (x/z, y/z) of X in the camera frame (no lens: the lens is not part of the correction). The
// rendering is correct for the camera when the n of all features are a planar perspective image of the pattern,
// n ~ H (a, b, 1) for the features' pattern coordinates (a, b). The error of each feature is the display
// displacement that would make it so: d = J^-1 (H(a, b) - n(p)), J = dn/dp (central differences of 0.5 display
// px), with H fitted by Gauss-Newton to minimise the sum of |d|^2 (display px) from a normalized DLT. The
// figure the tolerance applies to is the 95th percentile of |d| over the features the camera sees (inside its
// image, in front of it), as in the verification (VerifyOptions::tolerance_display_px).
//
// An exact rendering for the camera's position on the true monitor gives 0 (to ~1e-9 px); a misstated
// viewpoint or another true radius give the error a perfect detector would measure.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "pattern/pattern.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {

struct TrueCorrectionError {
  int features = 0;          // seen by the camera (in its image, in front of it)
  double p95_display_px = 0;  // 95th percentile of |d| (core/stats.h Percentile)
  double rms_display_px = 0, max_display_px = 0;
  std::vector<Eigen::Vector2d> error_display_px;  // d per seen feature, in the pattern's feature order
};

// The true error of `pattern` (its features' display positions on the nominal monitor `scene.monitor`) seen by
// `scene`'s camera on `scene.truth`. Throws Error when fewer than 5 features are seen (no homography to judge
// against).
TrueCorrectionError MeasureTrueCorrectionError(const SyntheticScene& scene, const Pattern& pattern);

}  // namespace curvecheck::experiments
