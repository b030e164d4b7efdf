// The correction of a monitor as a geometry warp (issue 19 part 3): for each display position, the normalized
// coordinate (u, v) in a SOURCE image that the display must show there, sampled on a grid that spans the display
// edge to edge and interpolated linearly between samples. This is what `curvecheck export-mpcdi` writes as the
// PFM of a VESA MPCDI 2d file (mpcdi/mpcdi_file.h).
//
// The source image is the planar perspective image an unaware application draws, exactly what `render --method
// none` draws (render/draw_plan.cc): the view from the viewpoint through the monitor taken as a flat W x H
// rectangle in the plane tangent to the screen at its centre (W the arc width, H the height; x right, y up).
// A display pixel must show what the ray from the viewpoint through its point on the screen surface sees; that
// ray crosses the tangent plane at (a, b) (core/correction.h PatternFromDisplayPx with TangentPlaneAtCentre),
// which the source image shows at u = (a + W/2)/W, v = (b + H/2)/H. The mapping does not depend on the content,
// so any image drawn with that frustum is corrected by the warp.
//
// Conventions (README "MPCDI export"):
//   u = 0 at the left edge, 1 at the right edge of the source image; v = 0 at the BOTTOM edge, 1 at the top;
//   source pixel (OpenCV convention, centres at integers) of (u, v): x = u Ws - 0.5, y = (1 - v) Hs - 0.5 for a
//   source image of Ws x Hs px;
//   grid sample (i, j), i = 0..cols-1 left to right, j = 0..rows-1 top to bottom, sits at display position
//   x = i/(cols-1) Nx - 0.5, y = j/(rows-1) Ny - 0.5 (pixel-centre coordinates): the first and last samples are
//   on the display's outer edges. A display position (x, y) reads the grid at fx = (x + 0.5)/Nx (cols - 1),
//   fy = (y + 0.5)/Ny (rows - 1), bilinearly.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/monitor.h"

namespace curvecheck {

// A displacement of the physical screen along the surface normal of the cylinder (toward the viewer positive,
// mm) over the display, as result.json "deviations.map" holds it: nv rows of nu values at the cell centres of
// (u, v) in [-1, 1]^2 (u fastest; v = -1 at the top, the display's convention), read bilinearly and held
// constant beyond the outermost centres. Cells without support (null in result.json) count as 0 mm.
struct DeviationMap {
  int nu = 0, nv = 0;
  std::vector<double> mm;  // nu * nv values, finite
  // Throws Error naming `where` unless nu, nv >= 1 and mm has nu nv finite values.
  void Check(const char* where) const;
  // Displacement (mm) at surface coordinates (u, v) (screen_geometry.h, -1..1 edge to edge, v down).
  double At(const Eigen::Vector2d& surface_uv) const;
};

// Exact (u, v) in the source image (conventions above) that display position `display_px` must show, for a
// monitor seen from `viewpoint_in_screen`, with the screen displaced by `deviation` (nullptr: the ideal
// cylinder of the monitor's radius). nullopt if the ray from the viewpoint through the screen point does not
// meet the tangent plane in front of the viewpoint (a viewpoint nearer the screen than its centre plane).
std::optional<Eigen::Vector2d> SourceUvFromDisplayPx(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                                                     const DeviationMap* deviation, const Eigen::Vector2d& display_px);

// Source pixel (OpenCV convention) of (u, v) in a source image of width x height px, and back.
Eigen::Vector2d SourcePxFromUv(const Eigen::Vector2d& uv, int width, int height);
Eigen::Vector2d UvFromSourcePx(const Eigen::Vector2d& source_px, int width, int height);

struct WarpGrid {
  int cols = 0, rows = 0;                          // samples across and down, >= 2 each
  int display_width_px = 0, display_height_px = 0;  // Nx, Ny: the display the grid spans
  // (u, v) per sample, row-major, row 0 = the TOP row of the display (the PFM stores the bottom row first).
  // Float: what the PFM holds (u to 6e-8, 3e-4 px on a 5120 px display).
  std::vector<Eigen::Vector2f> uv;

  const Eigen::Vector2f& At(int i, int j) const { return uv[static_cast<size_t>(j) * cols + i]; }
  // Display position (pixel-centre coordinates) of sample (i, j).
  Eigen::Vector2d SamplePx(int i, int j) const;
  // (u, v) at a display position, bilinear between the four samples around it (clamped to the grid at and
  // beyond the display's edges).
  Eigen::Vector2d Sample(const Eigen::Vector2d& display_px) const;
  // Throws Error naming `where` unless the sizes are consistent (cols, rows >= 2, uv has cols rows entries,
  // display size positive) and every value is finite.
  void Check(const char* where) const;
};

// The default grid for a display: one sample every kDefaultGridSpacingPx display px (rounded up), plus one,
// across and down. README "MPCDI export" has the interpolation error this gives (MeasureWarpInterpolation).
inline constexpr int kDefaultGridSpacingPx = 16;
std::pair<int, int> DefaultWarpGridSize(const Monitor& monitor);

// Samples the exact mapping (SourceUvFromDisplayPx) on a cols x rows grid. Throws Error ("viewpoint") if a
// sample has no source position (the viewpoint is too near the screen for a planar source image), or
// ("--grid") for fewer than 2 samples or more than 8192 in either direction.
WarpGrid MakeWarpGrid(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen, const DeviationMap* deviation,
                      int cols, int rows);

// How far the grid's bilinear interpolation puts each display pixel from where the exact mapping puts it,
// in DISPLAY px: at display pixel p the source-pixel error (interpolated - exact, in a source image of the
// display's size) mapped back through the local Jacobian of the exact mapping, |J^-1 e|. Measured on every
// `stride`-th pixel in x and y (stride 1: every pixel).
struct WarpInterpolationError {
  double max_px = 0, rms_px = 0;
  Eigen::Vector2d worst_display_px = Eigen::Vector2d::Zero();
  int64_t pixels = 0;
};
WarpInterpolationError MeasureWarpInterpolation(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                                                const DeviationMap* deviation, const WarpGrid& grid, int stride);

}  // namespace curvecheck
