// Accuracy of a correction method without any detector (issue 3 item 5): compare the pattern-plane
// coordinates each display pixel shows, as the method's own pipeline computed them (CoordinateImage), with
// the exact mapping of the geometry core (PatternFromDisplayPx, double precision), and express the
// difference in display pixels through the local Jacobian of the exact mapping.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/monitor.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {

struct MappingError {
  double rms_px = 0;
  double p99_px = 0;
  double max_px = 0;            // infinite if any pixel is missing
  double max_finite_px = 0;     // largest error over the pixels the method drew
  int64_t pixels = 0;          // pixels compared: those whose exact point lies on the pattern's cells
  int64_t missing_pixels = 0;  // of those, pixels the method left without coordinates (NaN): counted as failures
  // Per-pixel error in display px (row-major, display size); NaN where not compared.
  std::vector<float> map_px;
};

// Compares every pixel whose exact pattern point lies inside the pattern's cell grid (where every method must
// draw). Runs on all cores.
MappingError MeasureMappingError(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                                 const Pattern& pattern, const CoordinateImage& coordinates);

}  // namespace curvecheck
