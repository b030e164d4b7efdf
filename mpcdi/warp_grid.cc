#include "mpcdi/warp_grid.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "core/correction.h"
#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck {

void DeviationMap::Check(const char* where) const {
  if (nu < 1 || nv < 1 || mm.size() != static_cast<size_t>(nu) * static_cast<size_t>(nv)) {
    throw Error(where, fmt::format("deviation map of {} x {} cells has {} values", nu, nv, mm.size()),
                "give nu nv values, u fastest");
  }
  for (double v : mm) {
    if (!std::isfinite(v)) throw Error(where, "deviation map has a value that is not a finite number", "");
  }
}

double DeviationMap::At(const Eigen::Vector2d& uv) const {
  // Cell centre i is at u = -1 + (2 i + 1)/nu (analysis/screen_fit.cc writes the map so): fractional index
  // (u + 1) nu/2 - 0.5, clamped to the outermost centres.
  const double fx = std::clamp((uv.x() + 1) * 0.5 * nu - 0.5, 0.0, static_cast<double>(nu - 1));
  const double fy = std::clamp((uv.y() + 1) * 0.5 * nv - 0.5, 0.0, static_cast<double>(nv - 1));
  const int i0 = std::min(static_cast<int>(fx), std::max(0, nu - 2)), j0 = std::min(static_cast<int>(fy), std::max(0, nv - 2));
  const int i1 = std::min(i0 + 1, nu - 1), j1 = std::min(j0 + 1, nv - 1);
  const double ax = fx - i0, ay = fy - j0;
  auto m = [&](int i, int j) { return mm[static_cast<size_t>(j) * nu + i]; };
  return (1 - ay) * ((1 - ax) * m(i0, j0) + ax * m(i1, j0)) + ay * ((1 - ax) * m(i0, j1) + ax * m(i1, j1));
}

std::optional<Eigen::Vector2d> SourceUvFromDisplayPx(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                     const DeviationMap* deviation, const Eigen::Vector2d& display_px) {
  const PatternPlane tangent = TangentPlaneAtCentre(m);
  std::optional<Eigen::Vector2d> ab;
  if (deviation == nullptr) {
    ab = PatternFromDisplayPx(m, viewpoint, tangent, display_px);
  } else {
    // The displaced screen point, then the ray from the viewpoint through it to the tangent plane z = z_centre
    // (normal +z), the same construction as PatternFromDisplayPx with the surface moved along its normal.
    const Eigen::Vector2d suv = UvFromDisplayPx(m, display_px);
    const Eigen::Vector3d point = SurfacePointFromUv(m, suv) + deviation->At(suv) * SurfaceNormalFromUv(m, suv);
    const Eigen::Vector3d dir = point - viewpoint;
    const double t = (tangent.origin_in_screen.z() - viewpoint.z()) / dir.z();
    if (t > 0 && std::isfinite(t)) {
      const Eigen::Vector3d rel = (viewpoint - tangent.origin_in_screen) + t * dir;
      ab = Eigen::Vector2d(rel.x(), rel.y());
    }
  }
  if (!ab) return std::nullopt;
  return Eigen::Vector2d(ab->x() / m.width_mm + 0.5, ab->y() / m.height_mm + 0.5);
}

Eigen::Vector2d SourcePxFromUv(const Eigen::Vector2d& uv, int width, int height) {
  return {uv.x() * width - 0.5, (1 - uv.y()) * height - 0.5};
}

Eigen::Vector2d UvFromSourcePx(const Eigen::Vector2d& px, int width, int height) {
  return {(px.x() + 0.5) / width, 1 - (px.y() + 0.5) / height};
}

Eigen::Vector2d WarpGrid::SamplePx(int i, int j) const {
  return {static_cast<double>(i) / (cols - 1) * display_width_px - 0.5,
          static_cast<double>(j) / (rows - 1) * display_height_px - 0.5};
}

Eigen::Vector2d WarpGrid::Sample(const Eigen::Vector2d& p) const {
  const double fx = std::clamp((p.x() + 0.5) / display_width_px * (cols - 1), 0.0, static_cast<double>(cols - 1));
  const double fy = std::clamp((p.y() + 0.5) / display_height_px * (rows - 1), 0.0, static_cast<double>(rows - 1));
  const int i0 = std::min(static_cast<int>(fx), cols - 2), j0 = std::min(static_cast<int>(fy), rows - 2);
  const double ax = fx - i0, ay = fy - j0;
  const Eigen::Vector2d a = At(i0, j0).cast<double>(), b = At(i0 + 1, j0).cast<double>();
  const Eigen::Vector2d c = At(i0, j0 + 1).cast<double>(), d = At(i0 + 1, j0 + 1).cast<double>();
  return (1 - ay) * ((1 - ax) * a + ax * b) + ay * ((1 - ax) * c + ax * d);
}

void WarpGrid::Check(const char* where) const {
  if (cols < 2 || rows < 2 || display_width_px < 1 || display_height_px < 1 ||
      uv.size() != static_cast<size_t>(cols) * static_cast<size_t>(rows)) {
    throw Error(where,
                fmt::format("warp grid of {} x {} samples over a {} x {} px display holds {} samples", cols, rows,
                            display_width_px, display_height_px, uv.size()),
                "a grid needs at least 2 x 2 samples, one (u, v) each");
  }
  for (const Eigen::Vector2f& s : uv) {
    if (!s.allFinite()) throw Error(where, "warp grid has a sample that is not a finite number", "");
  }
}

std::pair<int, int> DefaultWarpGridSize(const Monitor& m) {
  return {(m.width_px + kDefaultGridSpacingPx - 1) / kDefaultGridSpacingPx + 1,
          (m.height_px + kDefaultGridSpacingPx - 1) / kDefaultGridSpacingPx + 1};
}

WarpGrid MakeWarpGrid(const Monitor& m, const Eigen::Vector3d& viewpoint, const DeviationMap* deviation, int cols,
                      int rows) {
  constexpr int kMaxSamples = 8192;
  if (cols < 2 || rows < 2 || cols > kMaxSamples || rows > kMaxSamples) {
    throw Error("--grid", fmt::format("{} x {} samples is not a warp grid", cols, rows),
                fmt::format("give 2 to {} samples across and down, e.g. --grid 321,91", kMaxSamples));
  }
  m.Check("monitor");
  CheckViewpoint(m, viewpoint, "viewpoint");
  if (deviation) deviation->Check("deviation map");
  WarpGrid g;
  g.cols = cols;
  g.rows = rows;
  g.display_width_px = m.width_px;
  g.display_height_px = m.height_px;
  g.uv.resize(static_cast<size_t>(cols) * rows);
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      const Eigen::Vector2d px = g.SamplePx(i, j);
      const std::optional<Eigen::Vector2d> uv = SourceUvFromDisplayPx(m, viewpoint, deviation, px);
      if (!uv || !uv->allFinite()) {
        throw Error("viewpoint",
                    fmt::format("the ray from the viewpoint through display position ({:.1f}, {:.1f}) px does not "
                                "meet the plane of the source image (the plane tangent to the screen at its centre) "
                                "in front of the viewpoint",
                                px.x(), px.y()),
                    "a planar source image cannot cover this view: move the viewpoint back");
      }
      g.uv[static_cast<size_t>(j) * cols + i] = uv->cast<float>();
    }
  }
  return g;
}

WarpInterpolationError MeasureWarpInterpolation(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                const DeviationMap* deviation, const WarpGrid& grid, int stride) {
  grid.Check("warp grid");
  if (stride < 1) throw Error("warp interpolation", fmt::format("stride {} is not positive", stride), "");
  const int w = m.width_px, h = m.height_px;
  auto exact_px = [&](const Eigen::Vector2d& p) -> std::optional<Eigen::Vector2d> {
    const auto uv = SourceUvFromDisplayPx(m, viewpoint, deviation, p);
    if (!uv) return std::nullopt;
    return SourcePxFromUv(*uv, w, h);
  };
  WarpInterpolationError out;
  double sum2 = 0;
  for (int y = 0; y < h; y += stride) {
    for (int x = 0; x < w; x += stride) {
      const Eigen::Vector2d p(x, y);
      const auto e = exact_px(p);
      // Forward differences, backward at the last column and row (the mapping is smooth over a pixel).
      const double dx = x + 1 < w ? 1 : -1, dy = y + 1 < h ? 1 : -1;
      const auto ex = exact_px(p + Eigen::Vector2d(dx, 0)), ey = exact_px(p + Eigen::Vector2d(0, dy));
      if (!e || !ex || !ey) continue;
      Eigen::Matrix2d jac;
      jac.col(0) = (*ex - *e) / dx;
      jac.col(1) = (*ey - *e) / dy;
      const Eigen::Vector2d got = SourcePxFromUv(grid.Sample(p), w, h);
      const double err = (jac.inverse() * (got - *e)).norm();
      sum2 += err * err;
      ++out.pixels;
      if (err > out.max_px) {
        out.max_px = err;
        out.worst_display_px = p;
      }
    }
  }
  out.rms_px = out.pixels ? std::sqrt(sum2 / static_cast<double>(out.pixels)) : 0;
  return out;
}

}  // namespace curvecheck
