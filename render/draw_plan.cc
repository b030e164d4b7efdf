// The per-method geometry of the renderer (render/draw_plan.h): CPU only, in double, no Vulkan.
#include "render/draw_plan.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "core/error.h"
#include "core/off_axis_projection.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

void Put(float* dst, const Eigen::Vector3d& v, double w = 0) {
  dst[0] = static_cast<float>(v.x());
  dst[1] = static_cast<float>(v.y());
  dst[2] = static_cast<float>(v.z());
  dst[3] = static_cast<float>(w);
}

// Vulkan clip space has y pointing down; the core's projections have y up.
Eigen::Matrix4d FlipY() {
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(1, 1) = -1;
  return f;
}

// The perspective frustum of thesis Eq 4.6 (OpenGL's glFrustum with depth 0..1): near-plane extents l, r, b, t
// (mm at the near distance n, y up), far distance f; eye space to clip space.
Eigen::Matrix4d Frustum(double l, double r, double b, double t, double n, double f) {
  Eigen::Matrix4d proj;
  proj << 2 * n / (r - l), 0, (r + l) / (r - l), 0,  //
      0, 2 * n / (t - b), (t + b) / (t - b), 0,       //
      0, 0, -f / (f - n), -(f * n) / (f - n),         //
      0, 0, -1, 0;
  return proj;
}

// Generalized perspective projection (Kooima, as used by thesis Eq 4.6) onto the planar rectangle with
// lower-left pa, lower-right pb and upper-left pc, from eye pe (all in the centre frame), to Vulkan clip space
// (y down, depth 0..1). Throws if the eye is not in front of the rectangle's plane.
Eigen::Matrix4d RectangleProjection(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& pc,
                                    const Eigen::Vector3d& pe, const std::string& what) {
  const Eigen::Vector3d vr = (pb - pa).normalized(), vu = (pc - pa).normalized(), vn = vr.cross(vu).normalized();
  const Eigen::Vector3d va = pa - pe, vb = pb - pe, vc = pc - pe;
  const double d = -va.dot(vn);
  if (!(d > 1e-3)) {
    throw Error("viewpoint", fmt::format("the viewpoint is {:.3f} mm in front of the plane of {}", d, what),
                "a perspective projection onto that plane cannot show it; use more strips or the exact method");
  }
  const double n = 1.0, f = 1e7;
  const double l = vr.dot(va) * n / d, r = vr.dot(vb) * n / d, b = vu.dot(va) * n / d, t = vu.dot(vc) * n / d;
  Eigen::Matrix4d rot = Eigen::Matrix4d::Identity();
  rot.block<1, 3>(0, 0) = vr.transpose();
  rot.block<1, 3>(1, 0) = vu.transpose();
  rot.block<1, 3>(2, 0) = vn.transpose();
  Eigen::Matrix4d trans = Eigen::Matrix4d::Identity();
  trans.block<3, 1>(0, 3) = -pe;
  return FlipY() * Frustum(l, r, b, t, n, f) * rot * trans;
}

// Affine map from plane coordinates (a, b, 0, 1) to centre-frame points.
Eigen::Matrix4d CentreFromAb(const PatternPlane& plane, const Eigen::Vector3d& origin_in_centre) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.block<3, 1>(0, 0) = plane.x_axis_in_screen;
  m.block<3, 1>(0, 1) = plane.y_axis_in_screen;
  m.block<3, 1>(0, 3) = origin_in_centre;
  m(3, 3) = 1;
  return m;
}

// The pattern's cell rectangle grown by one cell on each side, in plane coordinates (mm): what the geometric
// methods draw (outside it the clear colour is the surround).
struct PlaneRect {
  double a0 = 0, a1 = 0, b0 = 0, b1 = 0;
};
PlaneRect GrownCellRect(const PatternCells& c) {
  return {c.top_left_mm.x() - c.cell_mm, c.top_left_mm.x() + (c.width + 1) * c.cell_mm,
          c.top_left_mm.y() - (c.height + 1) * c.cell_mm, c.top_left_mm.y() + c.cell_mm};
}

// The framebuffer rectangle holding every pixel whose ray can meet the pattern's cells grown by one cell: the
// display bounding box of that rectangle's outline, sampled densely and grown by 2 px, clamped to the display.
// The whole display if any outline point does not map to the surface.
PixelRect PatternBoxPx(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern) {
  const auto [a0, a1, b0, b1] = GrownCellRect(pattern.cells);
  const PixelRect full{0, 0, static_cast<uint32_t>(m.width_px), static_cast<uint32_t>(m.height_px)};
  double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
  constexpr int kSamples = 512;
  for (int i = 0; i <= kSamples; ++i) {
    const double f = static_cast<double>(i) / kSamples;
    const double a = a0 + f * (a1 - a0), b = b0 + f * (b1 - b0);
    for (const Eigen::Vector2d& ab : {Eigen::Vector2d(a, b0), Eigen::Vector2d(a, b1), Eigen::Vector2d(a0, b),
                                      Eigen::Vector2d(a1, b)}) {
      const auto px = DisplayPxFromPattern(m, viewpoint, pattern.plane, ab);
      if (!px || !px->allFinite()) return full;
      x_lo = std::min(x_lo, px->x()), x_hi = std::max(x_hi, px->x());
      y_lo = std::min(y_lo, px->y()), y_hi = std::max(y_hi, px->y());
    }
  }
  // Display coordinate x covers framebuffer [x + 0.5 - 0.5, ...): pixel index floor(x + 0.5).
  const int x0 = std::clamp(static_cast<int>(std::floor(x_lo - 2)), 0, m.width_px);
  const int x1 = std::clamp(static_cast<int>(std::ceil(x_hi + 3)), 0, m.width_px);
  const int y0 = std::clamp(static_cast<int>(std::floor(y_lo - 2)), 0, m.height_px);
  const int y1 = std::clamp(static_cast<int>(std::ceil(y_hi + 3)), 0, m.height_px);
  if (x1 <= x0 || y1 <= y0) return full;
  return {x0, y0, static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)};
}

// Checks that the method can render this view correctly; throws Error naming the reason otherwise.
void CheckMethodApplies(const Monitor& m, const Eigen::Vector3d& viewpoint, const RenderOptions& o,
                        const DeviceLimits& limits) {
  CheckViewpoint(m, viewpoint, "viewpoint");
  if (o.method.method == Method::kWarp) MakeOffAxisFrustum(m, viewpoint);  // throws beyond 180 deg
  // Thesis 4.3.1 (after Eq 4.8): the cylindrical clip mapping of the tessellation method does not support
  // fields of view of 180 deg or more (viewpoints in front of the plane of the screen's corners).
  if (o.method.method == Method::kMesh && (viewpoint - ScreenCentreInScreen(m)).z() <= m.sagitta_mm()) {
    throw Error("viewpoint",
                fmt::format("the viewpoint is {:.1f} mm in front of the screen centre, inside the plane of its corners "
                            "({:.1f} mm): the field of view reaches 180 deg, which the mesh method's cylindrical "
                            "projection cannot render (thesis 4.3.1)",
                            (viewpoint - ScreenCentreInScreen(m)).z(), m.sagitta_mm()),
                "use the exact method");
  }
  if (o.method.method == Method::kMesh && !limits.tessellation) {
    throw Error("Vulkan", "the device has no tessellation shaders, which the mesh method needs",
                "use another method or device");
  }
}

// Refuses image sizes the device cannot hold rather than render nothing (lavapipe: 16384 px).
void CheckImageSize(uint64_t w, uint64_t h, const char* what, const DeviceLimits& limits) {
  if (w > limits.max_image_px || h > limits.max_image_px) {
    throw Error("render", fmt::format("{} of {}x{} px exceeds the device's limit of {} px ({})", what, w, h,
                                      limits.max_image_px, limits.device_name),
                "use a smaller display or warp scale, or another device");
  }
}

// The warp's first pass: the off-axis frustum of thesis Eq 4.6 (extents per 4.2.2) plus a guard band of 2 texels
// on each side, so that the cubic filter's taps at the display's edges read rendered texels, not clamped ones.
struct WarpFirstPass {
  ImageSize size;
  Eigen::Matrix4d clip_from_centre = Eigen::Matrix4d::Identity();  // centre-frame points to Vulkan clip space
};
constexpr int kWarpGuardTexels = 2;

ImageSize WarpImageSize(const Monitor& m, double scale) {
  return {static_cast<uint32_t>(std::lround(scale * m.width_px)) + 2 * kWarpGuardTexels,
          static_cast<uint32_t>(std::lround(scale * m.height_px)) + 2 * kWarpGuardTexels};
}

WarpFirstPass MakeWarpFirstPass(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                double scale) {
  const OffAxisFrustum fr = MakeOffAxisFrustum(m, viewpoint);
  const Eigen::Vector3d centre = ScreenCentreInScreen(m), eye = viewpoint - centre;
  WarpFirstPass w;
  w.size = WarpImageSize(m, scale);
  const uint32_t core_w = w.size.width - 2 * kWarpGuardTexels, core_h = w.size.height - 2 * kWarpGuardTexels;
  const double gx = kWarpGuardTexels * (fr.right_mm - fr.left_mm) / core_w;
  const double gy = kWarpGuardTexels * (fr.top_mm - fr.bottom_mm) / core_h;
  const double l = fr.left_mm - gx, r = fr.right_mm + gx, b = fr.bottom_mm - gy, t = fr.top_mm + gy;
  const double n = fr.near_mm;
  // The first pass clips at the near plane (the plane of the screen's corners): a pattern plane that comes nearer
  // than that somewhere in the drawn rectangle would be cut silently, so refuse.
  const auto [a0, a1, b0, b1] = GrownCellRect(pattern.cells);
  for (const auto& [ca, cb] : {std::pair(a0, b0), std::pair(a1, b0), std::pair(a0, b1), std::pair(a1, b1)}) {
    const Eigen::Vector3d corner = pattern.plane.PointInScreen({ca, cb}) - centre;
    if (eye.z() - corner.z() < n * (1 - 1e-9)) {  // on the near plane itself is drawn (flat screens)
      throw Error("pattern plane",
                  "part of the pattern lies in front of the plane of the screen's corners, where the warp's linear "
                  "first pass clips it",
                  "use a pattern plane behind the screen, or the exact method");
    }
  }
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();  // translation by -O, in the centre frame
  view.block<3, 1>(0, 3) = -eye;
  w.clip_from_centre = FlipY() * Frustum(l, r, b, t, n, fr.far_mm) * view;  // Eq 4.6 with the widened extents
  return w;
}

// mesh: the tessellator is never asked for more than kMaxTessLevel segments per edge: a higher uniform level splits
// the patches instead, which is the same geometry (and the draws are batched, kMaxTrianglesPerDraw).
int MeshSplit(const MethodOptions& mo) {
  return mo.mesh_subdivision == MeshSubdivision::kUniform ? (mo.mesh_level + kMaxTessLevel - 1) / kMaxTessLevel : 1;
}

ShaderParams MakeParams(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                        const RenderOptions& o, const Eigen::Matrix4d& warp_clip_from_centre, ImageSize intermediate) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  const PatternCells& cells = pattern.cells;
  const MethodOptions& mo = o.method;
  ShaderParams p{};
  p.monitor[0] = static_cast<float>(m.width_px);
  p.monitor[1] = static_cast<float>(m.height_px);
  p.monitor[2] = static_cast<float>(m.width_mm);
  p.monitor[3] = static_cast<float>(m.height_mm);
  p.monitor2[0] = static_cast<float>(m.curvature_per_mm);
  p.monitor2[1] = static_cast<float>(o.display_gamma);
  p.monitor2[2] = static_cast<float>(std::pow(o.surround_code / 255.0, o.display_gamma));
  Put(p.viewpoint, viewpoint - centre);
  Put(p.plane_origin, pattern.plane.origin_in_screen - centre);
  Put(p.plane_x, pattern.plane.x_axis_in_screen);
  Put(p.plane_y, pattern.plane.y_axis_in_screen);
  Put(p.plane_n, pattern.plane.Normal());
  p.cells[0] = static_cast<float>(cells.cell_mm);
  p.cells[1] = static_cast<float>(cells.top_left_mm.x());
  p.cells[2] = static_cast<float>(cells.top_left_mm.y());
  p.cells_size[0] = cells.width;
  p.cells_size[1] = cells.height;
  p.mesh[0] = mo.mesh_subdivision == MeshSubdivision::kUniform ? 0.f
              : mo.mesh_subdivision == MeshSubdivision::kPerez ? 1.f
                                                               : 2.f;
  p.mesh[1] = static_cast<float>(mo.mesh_level) / static_cast<float>(MeshSplit(mo));
  p.mesh[2] = static_cast<float>(mo.mesh_tolerance_px);
  if (mo.method == Method::kWarp) {
    p.warp[0] = static_cast<float>(intermediate.width);
    p.warp[1] = static_cast<float>(intermediate.height);
  }
  // exact: the ray's constant terms, in double (ExactDraws).
  const Eigen::Vector3d eye = viewpoint - centre, origin = pattern.plane.origin_in_screen - centre;
  p.exact[0] = static_cast<float>(pattern.plane.Normal().dot(origin - eye));
  p.exact[1] = static_cast<float>((eye - origin).dot(pattern.plane.x_axis_in_screen));
  p.exact[2] = static_cast<float>((eye - origin).dot(pattern.plane.y_axis_in_screen));
  const auto clip = ColumnMajorFloats(warp_clip_from_centre);
  std::memcpy(p.clip_from_centre, clip.data(), sizeof(p.clip_from_centre));
  return p;
}

// DrawPlan::surface_xz and surface_y: the surface at every pixel edge and centre.
void FillSurfaceTables(const Monitor& m, DrawPlan* plan) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  plan->surface_xz.resize(2 * (2 * static_cast<size_t>(m.width_px) + 1));
  for (size_t k = 0; k <= 2 * static_cast<size_t>(m.width_px); ++k) {
    const Eigen::Vector3d s = SurfacePointFromUv(m, UvFromDisplayPx(m, {0.5 * k - 0.5, 0})) - centre;
    plan->surface_xz[2 * k] = static_cast<float>(s.x());
    plan->surface_xz[2 * k + 1] = static_cast<float>(s.z());
  }
  plan->surface_y.resize(2 * static_cast<size_t>(m.height_px) + 1);
  for (size_t k = 0; k < plan->surface_y.size(); ++k) {
    plan->surface_y[k] =
        static_cast<float>((SurfacePointFromUv(m, UvFromDisplayPx(m, {0, 0.5 * k - 0.5})) - centre).y());
  }
}

CellLabels MakeCellLabels(const PatternCells& cells) {
  CellLabels c;
  c.size = {static_cast<uint32_t>(cells.width) + 2, static_cast<uint32_t>(cells.height) + 2};
  c.labels.assign(static_cast<size_t>(c.size.width) * c.size.height, uint8_t{2});
  for (int r = 0; r < cells.height; ++r) {
    for (int col = 0; col < cells.width; ++col) {
      c.labels[static_cast<size_t>(r + 1) * c.size.width + static_cast<size_t>(col + 1)] =
          cells.Value(col, r) >= 128 ? 1 : 0;
    }
  }
  return c;
}

// mesh: the grown cell rectangle as quad patches of at most mesh_patch_px (at the screen centre, split per
// MeshSplit), corners (a, b) counter-clockwise from the bottom left.
std::vector<float> MeshPatches(const Monitor& m, const PlaneRect& rect, const MethodOptions& mo) {
  const auto [a0, a1, b0, b1] = rect;
  const double patch_mm = mo.mesh_patch_px * m.pixel_pitch_mm() / MeshSplit(mo);
  const int na = std::max(1, static_cast<int>(std::ceil((a1 - a0) / patch_mm)));
  const int nb = std::max(1, static_cast<int>(std::ceil((b1 - b0) / patch_mm)));
  std::vector<float> vertices;
  vertices.reserve(static_cast<size_t>(na) * nb * 8);
  for (int j = 0; j < nb; ++j) {
    for (int i = 0; i < na; ++i) {
      const double x0 = a0 + (a1 - a0) * i / na, x1 = a0 + (a1 - a0) * (i + 1) / na;
      const double y0 = b0 + (b1 - b0) * j / nb, y1 = b0 + (b1 - b0) * (j + 1) / nb;
      for (const auto& [x, y] : {std::pair(x0, y0), std::pair(x1, y0), std::pair(x1, y1), std::pair(x0, y1)}) {
        vertices.push_back(static_cast<float>(x));
        vertices.push_back(static_cast<float>(y));
      }
    }
  }
  return vertices;
}

// warp through a distortion grid: two triangles per cell of a display grid; each vertex holds its (u, v), which is
// its clip position, and its exact texel coordinates in the first-pass image.
std::vector<float> WarpGrid(const Monitor& m, const MethodOptions& mo, const WarpFirstPass& first) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  const double inter_w = first.size.width, inter_h = first.size.height;
  std::vector<float> vertices;
  vertices.reserve(static_cast<size_t>(mo.warp_grid_cols) * mo.warp_grid_rows * 6 * 4);
  auto vertex = [&](int i, int j) {
    const Eigen::Vector2d px(-0.5 + m.width_px * static_cast<double>(i) / mo.warp_grid_cols,
                             -0.5 + m.height_px * static_cast<double>(j) / mo.warp_grid_rows);
    const Eigen::Vector2d uv = UvFromDisplayPx(m, px);
    const Eigen::Vector3d s = SurfacePointFromUv(m, uv) - centre;
    const Eigen::Vector4d c = first.clip_from_centre * s.homogeneous();
    const Eigen::Vector2d texel((c.x() / c.w() * 0.5 + 0.5) * inter_w - 0.5,
                                (c.y() / c.w() * 0.5 + 0.5) * inter_h - 0.5);
    for (double v : {uv.x(), uv.y(), texel.x(), texel.y()}) vertices.push_back(static_cast<float>(v));
  };
  for (int j = 0; j < mo.warp_grid_rows; ++j) {
    for (int i = 0; i < mo.warp_grid_cols; ++i) {
      for (const auto& [di, dj] :
           {std::pair(0, 0), std::pair(1, 0), std::pair(1, 1), std::pair(0, 0), std::pair(1, 1), std::pair(0, 1)}) {
        vertex(i + di, j + dj);
      }
    }
  }
  return vertices;
}

std::vector<float> QuadVertices(const PlaneRect& r) {
  return {static_cast<float>(r.a0), static_cast<float>(r.b0), static_cast<float>(r.a1), static_cast<float>(r.b0),
          static_cast<float>(r.a0), static_cast<float>(r.b1), static_cast<float>(r.a1), static_cast<float>(r.b1)};
}

Viewport FullViewport(ImageSize s) { return {0, 0, static_cast<double>(s.width), static_cast<double>(s.height)}; }
PixelRect FullRect(ImageSize s) { return {0, 0, s.width, s.height}; }

// strips: N vertical slices of the display, each a perspective projection onto the chord rectangle of its
// part of the surface; a slice narrower than a pixel covers no pixel centre and is not drawn.
std::vector<DrawCall> StripDraws(const Monitor& m, const Eigen::Vector3d& eye, const Eigen::Matrix4d& centre_from_ab,
                                 int strips) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  const uint32_t height = static_cast<uint32_t>(m.height_px);
  std::vector<DrawCall> draws;
  for (int i = 0; i < strips; ++i) {
    const double u0 = -1 + 2.0 * i / strips, u1 = -1 + 2.0 * (i + 1) / strips;
    const Eigen::Vector3d pa = SurfacePointFromUv(m, {u0, 1}) - centre, pb = SurfacePointFromUv(m, {u1, 1}) - centre;
    const Eigen::Vector3d pc = SurfacePointFromUv(m, {u0, -1}) - centre;
    const double e0 = 0.5 * (u0 + 1) * m.width_px, e1 = 0.5 * (u1 + 1) * m.width_px;  // framebuffer x of edges
    const int32_t s0 = static_cast<int32_t>(std::ceil(e0 - 0.5)), s1 = static_cast<int32_t>(std::ceil(e1 - 0.5));
    if (s1 <= s0) continue;
    draws.push_back({0, 4, {e0, 0, e1 - e0, static_cast<double>(height)},
                     {s0, 0, static_cast<uint32_t>(s1 - s0), height},
                     RectangleProjection(pa, pb, pc, eye, fmt::format("strip {}", i)) * centre_from_ab});
  }
  return draws;
}

// exact: the ray through each pixel's surface point s meets the plane at t = n . (p0 - o) / (n . d), d = s - o, and
// its plane coordinates are ((o - p0) . x_p, (o - p0) . y_p) + t (x_p . d, y_p . d) (o the viewpoint, p0, x_p,
// y_p, n the plane's origin and axes). Those constants are ShaderParams::exact; what varies per pixel is
// r = (n . d, x_p . d, y_p . d), linear in s. The display is cut into vertical strips of w columns; along a strip
// s runs on a circular arc (its height is linear in the row), and r is interpolated from its exact values at the
// strip's edges (linearly in the column, by the rasterizer) plus the quadratic through its exact value at the
// middle: r(u) = r0 (1 - u) + r1 u + 4 u (1 - u) (r_mid - (r0 + r1) / 2), u = 0 .. 1 across the strip. The
// quadratic's error on an arc of curvature kappa and half-length h is at most kappa^2 h^3 / (9 sqrt 3) (through 3
// points, the bound is max |s'''| h^3 / (9 sqrt 3), and |s'''| = kappa^2); w is the widest strip, a multiple of
// 4 columns (no 4 x 4 block of llvmpipe's straddles two strips), whose bound is below 1e-5 px, far below float
// rounding (~1e-4 px): 28 columns on a 49" 1000R panel.
// Each strip is two triangles, (c0, 0), (c1, 0), (c0, Ny) and (c1, 0), (c1, Ny), (c0, Ny) in framebuffer px, with
// r exact at its corners; the strips that meet the pattern's box are one draw, scissored to that box. (Each
// pixel's ray from a per-column table of s cost 1.7-1.9x `none` on llvmpipe, most of the difference its
// per-pixel reads. One triangle per strip holding the whole strip, one draw each, rounded the extrapolated
// vertices' r more: 0.003-0.004 px of mapping error against 0.0006.)
// Vertices: 6 per strip, 9 floats each: clip x, y; r there; u; the bow r_mid - (r0 + r1) / 2 (the same at every
// row: the row moves s along y only, which adds the same to r across the strip).
int ExactStripColumns(const Monitor& m) {
  const double kappa = std::abs(m.curvature_per_mm), pitch = m.pixel_pitch_mm();
  if (kappa == 0) return m.width_px;  // flat: r is linear in the column
  const double half_mm = std::cbrt(1e-5 * pitch * 9 * std::sqrt(3.0) / (kappa * kappa));
  return std::clamp(4 * static_cast<int>(std::floor(half_mm / pitch / 2)), 4, m.width_px);
}

std::vector<DrawCall> ExactDraws(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                 const PixelRect& box, int w, std::vector<float>* vertices) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(m), eye = viewpoint - centre;
  const PatternPlane& plane = pattern.plane;
  const Eigen::Vector3d n = plane.Normal(), x_p = plane.x_axis_in_screen, y_p = plane.y_axis_in_screen;
  // r at framebuffer (x, y), display coordinates (x - 0.5, y - 0.5).
  const auto ray = [&](double x, double y) {
    const Eigen::Vector3d d = SurfacePointFromUv(m, UvFromDisplayPx(m, {x - 0.5, y - 0.5})) - centre - eye;
    return Eigen::Vector3d(n.dot(d), x_p.dot(d), y_p.dot(d));
  };
  const double nx = m.width_px, ny = m.height_px;
  const int box_x1 = box.x + static_cast<int>(box.width);
  for (int c0 = 0; c0 < m.width_px; c0 += w) {
    const int c1 = std::min(c0 + w, m.width_px);
    if (c1 <= box.x || c0 >= box_x1) continue;
    const Eigen::Vector3d bow = ray(0.5 * (c0 + c1), 0) - 0.5 * (ray(c0, 0) + ray(c1, 0));
    const auto vertex = [&](int x, int y) {
      const Eigen::Vector3d r = ray(x, y);
      const double u = x == c0 ? 0.0 : 1.0;
      for (const double f : {2 * x / nx - 1, 2 * y / ny - 1, r.x(), r.y(), r.z(), u, bow.x(), bow.y(), bow.z()}) {
        vertices->push_back(static_cast<float>(f));
      }
    };
    vertex(c0, 0), vertex(c1, 0), vertex(c0, m.height_px);
    vertex(c1, 0), vertex(c1, m.height_px), vertex(c0, m.height_px);
  }
  const ImageSize display{static_cast<uint32_t>(m.width_px), static_cast<uint32_t>(m.height_px)};
  return {{0, static_cast<uint32_t>(vertices->size() / 9), FullViewport(display), box, {}}};
}

// mesh: the patches in batches of at most kMaxTrianglesPerDraw triangles (2 level^2 per patch).
std::vector<DrawCall> MeshDraws(size_t vertex_floats, double level, ImageSize display) {
  const uint32_t patches = static_cast<uint32_t>(vertex_floats / 8);
  const uint32_t batch = std::max<uint32_t>(1, static_cast<uint32_t>(kMaxTrianglesPerDraw / (2 * level * level)));
  std::vector<DrawCall> draws;
  for (uint32_t first = 0; first < patches; first += batch) {
    draws.push_back({4 * first, 4 * std::min(batch, patches - first), FullViewport(display), FullRect(display), {}});
  }
  return draws;
}

}  // namespace

std::array<float, 16> ColumnMajorFloats(const Eigen::Matrix4d& m) {
  std::array<float, 16> out;
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) out[static_cast<size_t>(c * 4 + r)] = static_cast<float>(m(r, c));
  }
  return out;
}

DrawPlan MakeDrawPlan(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                      const RenderOptions& o, RenderOutput output, const DeviceLimits& limits) {
  o.Check("render options");
  CheckMethodApplies(m, viewpoint, o, limits);
  const MethodOptions& mo = o.method;
  const bool coordinates = output == RenderOutput::kCoordinates;
  CheckImageSize(static_cast<uint64_t>(m.width_px), static_cast<uint64_t>(m.height_px), "the display", limits);
  CheckImageSize(static_cast<uint64_t>(pattern.cells.width) + 2, static_cast<uint64_t>(pattern.cells.height) + 2,
                 "the pattern's cell grid", limits);
  if (mo.method == Method::kWarp) {
    const ImageSize s = WarpImageSize(m, mo.warp_scale);
    CheckImageSize(s.width, s.height, "the warp's first-pass image", limits);
  }

  DrawPlan plan;
  plan.display = {static_cast<uint32_t>(m.width_px), static_cast<uint32_t>(m.height_px)};
  plan.display_format = coordinates ? TexelFormat::kCoordinates : TexelFormat::kShade8;
  plan.intermediate_format = coordinates ? TexelFormat::kCoordinates : TexelFormat::kLinear32;
  WarpFirstPass warp;
  if (mo.method == Method::kWarp) {
    warp = MakeWarpFirstPass(m, viewpoint, pattern, mo.warp_scale);
    plan.intermediate = warp.size;
  }
  plan.params = MakeParams(m, viewpoint, pattern, o, warp.clip_from_centre, plan.intermediate);
  plan.exact_supersample = mo.antialiasing == AntiAliasing::kSupersample ? mo.supersample : 0;
  plan.warp_cubic = mo.warp_filter == WarpFilter::kCubic;

  FillSurfaceTables(m, &plan);
  plan.cells = MakeCellLabels(pattern.cells);

  const Eigen::Vector3d centre = ScreenCentreInScreen(m);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::array<float, 4> display_clear =
      coordinates ? std::array<float, 4>{nan, nan, 0, 1}
                  : std::array<float, 4>{static_cast<float>(o.surround_code / 255.0), 0, 0, 1};
  const std::array<float, 4> intermediate_clear =
      coordinates ? std::array<float, 4>{nan, nan, 0, 1} : std::array<float, 4>{plan.params.monitor2[2], 0, 0, 1};
  const PlaneRect rect = GrownCellRect(pattern.cells);
  const Eigen::Matrix4d centre_from_ab = CentreFromAb(pattern.plane, pattern.plane.origin_in_screen - centre);
  const Eigen::Vector3d eye = viewpoint - centre;
  const Viewport full_viewport = FullViewport(plan.display);
  const PixelRect full_rect = FullRect(plan.display);
  Pass pass;
  pass.clear_colour = display_clear;
  switch (mo.method) {
    case Method::kExact:
      // Only the pattern's bounding box is ray cast; around it the clear colour is the surround, which is what
      // the ray cast would show there.
      pass.pipeline = PipelineKind::kExact;
      // Supersampled, the shader casts each sample's ray itself (SurfacePoint) and reads no interpolated ray:
      // one strip (two triangles) then spares the blocks on the strips' diagonals, shaded by both triangles.
      pass.draws = ExactDraws(m, viewpoint, pattern, PatternBoxPx(m, viewpoint, pattern),
                              plan.exact_supersample > 0 ? m.width_px : ExactStripColumns(m), &pass.vertices);
      break;
    case Method::kNone: {
      // The panel taken as flat: a W x H rectangle in the plane tangent at the screen centre.
      const double hw = 0.5 * m.width_mm, hh = 0.5 * m.height_mm;
      pass.pipeline = PipelineKind::kQuad;
      pass.vertices = QuadVertices(rect);
      pass.draws.push_back(
          {0, 4, full_viewport, full_rect,
           RectangleProjection({-hw, -hh, 0}, {hw, -hh, 0}, {-hw, hh, 0}, eye, "the flat screen") * centre_from_ab});
      break;
    }
    case Method::kStrips:
      pass.pipeline = PipelineKind::kQuad;
      pass.vertices = QuadVertices(rect);
      pass.draws = StripDraws(m, eye, centre_from_ab, mo.strips);
      break;
    case Method::kWarp: {
      Pass first;
      first.pipeline = coordinates ? PipelineKind::kQuad : PipelineKind::kQuadLinear;
      first.target = PassTarget::kIntermediate;
      first.clear_colour = intermediate_clear;
      first.vertices = QuadVertices(rect);
      first.draws.push_back(
          {0, 4, FullViewport(warp.size), FullRect(warp.size), warp.clip_from_centre * centre_from_ab});
      plan.passes.push_back(std::move(first));
      if (mo.warp_grid_cols > 0) {
        pass.pipeline = PipelineKind::kWarpGrid;
        pass.vertices = WarpGrid(m, mo, warp);
      } else {
        pass.pipeline = PipelineKind::kWarpPerFragment;
      }
      const uint32_t count = pass.vertices.empty() ? 3 : static_cast<uint32_t>(pass.vertices.size() / 4);
      pass.draws.push_back({0, count, full_viewport, full_rect, {}});
      break;
    }
    case Method::kMesh: {
      pass.pipeline = PipelineKind::kMesh;
      pass.vertices = MeshPatches(m, rect, mo);
      const double level = mo.mesh_subdivision == MeshSubdivision::kUniform ? plan.params.mesh[1] : kMaxTessLevel;
      pass.draws = MeshDraws(pass.vertices.size(), level, plan.display);
      break;
    }
  }
  plan.passes.push_back(std::move(pass));
  return plan;
}

}  // namespace curvecheck
