#include "render/mapping_error.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/correction.h"
#include "core/error.h"
#include "core/parallel.h"

namespace curvecheck {

MappingError MeasureMappingError(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                 const CoordinateImage& coords) {
  if (coords.width != m.width_px || coords.height != m.height_px) {
    throw Error("mapping error", "coordinate image size does not match the monitor", "render for this monitor");
  }
  const int w = m.width_px, h = m.height_px;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Exact plane coordinates of every pixel centre, and one extra column and row for forward differences.
  std::vector<Eigen::Vector2d> exact(static_cast<size_t>(w + 1) * (h + 1));
  ParallelFor(h + 1, [&](int y) {
    for (int x = 0; x <= w; ++x) {
      const auto ab = PatternFromDisplayPx(m, viewpoint, pattern.plane, {x, y});
      exact[static_cast<size_t>(y) * (w + 1) + x] = ab ? *ab : Eigen::Vector2d(nan, nan);
    }
  });
  const PatternCells& c = pattern.cells;
  const double a_lo = c.top_left_mm.x(), a_hi = a_lo + c.width * c.cell_mm;
  const double b_hi = c.top_left_mm.y(), b_lo = b_hi - c.height * c.cell_mm;

  MappingError out;
  out.map_px.assign(static_cast<size_t>(w) * h, nan);
  std::vector<int64_t> counted(static_cast<size_t>(h), 0), missing(static_cast<size_t>(h), 0);
  ParallelFor(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d& e = exact[static_cast<size_t>(y) * (w + 1) + x];
      if (!(e.x() >= a_lo && e.x() <= a_hi && e.y() >= b_lo && e.y() <= b_hi)) continue;
      ++counted[static_cast<size_t>(y)];
      const size_t i = static_cast<size_t>(y) * w + x;
      const Eigen::Vector2d got(coords.ab[2 * i], coords.ab[2 * i + 1]);
      if (!got.allFinite()) {
        ++missing[static_cast<size_t>(y)];
        out.map_px[i] = std::numeric_limits<float>::infinity();
        continue;
      }
      // d(ab)/d(px) by forward differences of the exact map; the error in px is J^-1 (got - exact).
      Eigen::Matrix2d jac;
      jac.col(0) = exact[static_cast<size_t>(y) * (w + 1) + x + 1] - e;
      jac.col(1) = exact[static_cast<size_t>(y + 1) * (w + 1) + x] - e;
      out.map_px[i] = static_cast<float>((jac.inverse() * (got - e)).norm());
    }
  });
  std::vector<float> errors;
  errors.reserve(static_cast<size_t>(w) * h);
  double sum2 = 0;
  for (float v : out.map_px) {
    if (std::isnan(v)) continue;
    errors.push_back(v);
    if (std::isfinite(v)) {
      sum2 += static_cast<double>(v) * v;
      out.max_finite_px = std::max(out.max_finite_px, static_cast<double>(v));
    }
  }
  for (int y = 0; y < h; ++y) {
    out.pixels += counted[static_cast<size_t>(y)];
    out.missing_pixels += missing[static_cast<size_t>(y)];
  }
  if (errors.empty()) return out;
  const size_t finite = errors.size() - static_cast<size_t>(out.missing_pixels);
  out.rms_px = finite ? std::sqrt(sum2 / static_cast<double>(finite)) : 0;
  const size_t k99 = std::min(errors.size() - 1, static_cast<size_t>(0.99 * static_cast<double>(errors.size())));
  std::nth_element(errors.begin(), errors.begin() + static_cast<long>(k99), errors.end());
  out.p99_px = errors[k99];
  out.max_px = *std::max_element(errors.begin(), errors.end());
  return out;
}

}  // namespace curvecheck
