// Draw plans (render/draw_plan.h) checked on the CPU, with no Vulkan device: each method's passes, draws and
// vertex data against the analytic geometry of the screen (core/screen_geometry.h) and the off-axis frustum
// (core/off_axis_projection.h). What the GPU then makes of a plan (rasterization, the shaders' per-pixel and
// per-vertex projection, e.g. the mesh's tessellation onto the cylinder) is measured by renderer_test.cc.
#include "render/draw_plan.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <iostream>

#include "core/correction.h"
#include "core/error.h"
#include "core/off_axis_projection.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

using ::testing::HasSubstr;

const DeviceLimits kLimits{16384, true, "test device"};

// The reference configuration of renderer_test.cc: a 34" 3440x1440 panel bent to 1000R.
struct Scene {
  Monitor monitor;
  Eigen::Vector3d eye;
  Pattern pattern;
};
Scene Reference(const Eigen::Vector3d& eye_from_centre = {0, 0, 600}, double margin = 0.01) {
  Scene s;
  s.monitor = MonitorFromDiagonal("34 1000R", 3440, 1440, 34, 1000);
  s.eye = ScreenCentreInScreen(s.monitor) + eye_from_centre;
  PatternSpec spec;
  spec.cols = 16;
  spec.rows = 6;
  spec.margin = margin;
  s.pattern = BuildPattern(spec, s.monitor, s.eye, TangentPlaneAtCentre(s.monitor));
  return s;
}

DrawPlan Plan(const Scene& s, const MethodOptions& method, RenderOutput output = RenderOutput::kShade,
              const DeviceLimits& limits = kLimits) {
  RenderOptions o;
  o.method = method;
  return MakeDrawPlan(s.monitor, s.eye, s.pattern, o, output, limits);
}

MethodOptions Options(Method method) {
  MethodOptions o;
  o.method = method;
  return o;
}

// Framebuffer position of clip-space point c (homogeneous) through the viewport.
Eigen::Vector2d Framebuffer(const Viewport& vp, const Eigen::Vector4d& c) {
  return {vp.x + 0.5 * (c.x() / c.w() + 1) * vp.width, vp.y + 0.5 * (c.y() / c.w() + 1) * vp.height};
}

// Display position (pixel centres at integers) where a draw puts plane point ab.
Eigen::Vector2d DisplayPxOfDraw(const DrawCall& d, const Eigen::Vector2d& ab) {
  return Framebuffer(d.viewport, *d.clip_from_ab * Eigen::Vector4d(ab.x(), ab.y(), 0, 1)) - Eigen::Vector2d(0.5, 0.5);
}

// Plane coordinates of the point where the ray from the eye through point_in_screen meets the pattern plane.
Eigen::Vector2d PlaneAbAlongRay(const Scene& s, const Eigen::Vector3d& point_in_screen) {
  const PatternPlane& p = s.pattern.plane;
  const Eigen::Vector3d d = point_in_screen - s.eye;
  const double t = p.Normal().dot(p.origin_in_screen - s.eye) / p.Normal().dot(d);
  const Eigen::Vector3d q = s.eye + t * d - p.origin_in_screen;
  return {q.dot(p.x_axis_in_screen), q.dot(p.y_axis_in_screen)};
}

// Every method: each target drawn by one pass at most, the intermediate before the display; every draw within its
// pass's vertex data; push constants exactly on the quad pipelines.
TEST(DrawPlan, EveryMethodGivesAWellFormedPlan) {
  const Scene s = Reference({120, -40, 650});
  MethodOptions grid = Options(Method::kWarp);
  grid.warp_grid_cols = 20;
  grid.warp_grid_rows = 9;
  for (const MethodOptions& method : {Options(Method::kExact), Options(Method::kWarp), grid, Options(Method::kMesh),
                                      Options(Method::kStrips), Options(Method::kNone)}) {
    for (RenderOutput output : {RenderOutput::kShade, RenderOutput::kCoordinates}) {
      SCOPED_TRACE(method.Label());
      const DrawPlan plan = Plan(s, method, output);
      EXPECT_EQ(plan.display.width, 3440u);
      EXPECT_EQ(plan.display.height, 1440u);
      EXPECT_EQ(plan.display_format,
                output == RenderOutput::kShade ? TexelFormat::kShade8 : TexelFormat::kCoordinates);
      ASSERT_FALSE(plan.passes.empty());
      EXPECT_EQ(plan.passes.back().target, PassTarget::kDisplay);
      for (size_t p = 0; p + 1 < plan.passes.size(); ++p) EXPECT_EQ(plan.passes[p].target, PassTarget::kIntermediate);
      EXPECT_LE(plan.passes.size(), 2u);
      for (const Pass& pass : plan.passes) {
        const bool quad = pass.pipeline == PipelineKind::kQuad || pass.pipeline == PipelineKind::kQuadLinear;
        const size_t stride = pass.pipeline == PipelineKind::kWarpGrid ? 4 : 2;
        ASSERT_FALSE(pass.draws.empty());
        for (const DrawCall& d : pass.draws) {
          EXPECT_EQ(d.clip_from_ab.has_value(), quad);
          if (pass.vertices.empty()) {
            EXPECT_EQ(d.vertex_count, 3u);  // one triangle over the viewport, made by the vertex shader
          } else {
            EXPECT_LE((d.first_vertex + d.vertex_count) * stride, pass.vertices.size());
          }
        }
      }
    }
  }
}

// strips N: N perspective slices whose viewports tile the display's width exactly, each drawing the pixel
// columns whose centres it covers; slices narrower than a pixel centre gap draw nothing and are left out.
TEST(StripsPlan, SlicesTileTheDisplayExactly) {
  const Scene s = Reference();
  for (int n : {1, 7, 32, 128, 4096}) {
    SCOPED_TRACE(n);
    MethodOptions o = Options(Method::kStrips);
    o.strips = n;
    const DrawPlan plan = Plan(s, o);
    ASSERT_EQ(plan.passes.size(), 1u);
    const Pass& pass = plan.passes[0];
    EXPECT_EQ(pass.pipeline, PipelineKind::kQuad);
    // Narrower slices than a pixel: one per pixel centre.
    EXPECT_EQ(pass.draws.size(), static_cast<size_t>(std::min(n, 3440)));
    double right = 0;
    int32_t next_column = 0;
    for (const DrawCall& d : pass.draws) {
      if (n <= 3440) {
        EXPECT_DOUBLE_EQ(d.viewport.x, right);
      }
      EXPECT_NEAR(d.viewport.width, 3440.0 / n, 1e-9);
      EXPECT_EQ(d.viewport.y, 0);
      EXPECT_EQ(d.viewport.height, 1440);
      EXPECT_EQ(d.scissor.x, next_column);
      EXPECT_EQ(d.scissor.x, static_cast<int32_t>(std::ceil(d.viewport.x - 0.5)));  // first column centre inside
      EXPECT_EQ(d.scissor.y, 0);
      EXPECT_EQ(d.scissor.height, 1440u);
      right = d.viewport.x + d.viewport.width;
      next_column = d.scissor.x + static_cast<int32_t>(d.scissor.width);
    }
    EXPECT_NEAR(right, 3440, 1e-9);
    EXPECT_EQ(next_column, 3440);
  }
}

// Each slice projects onto the chord rectangle of its part of the surface: the surface points on a slice's two
// edges lie on that rectangle, so they are drawn exactly where the display shows them.
TEST(StripsPlan, EachSliceIsExactOnItsEdges) {
  const Scene s = Reference({-150, 60, 700});
  MethodOptions o = Options(Method::kStrips);
  o.strips = 8;
  const DrawPlan plan = Plan(s, o);
  ASSERT_EQ(plan.passes[0].draws.size(), 8u);
  for (int i = 0; i < 8; ++i) {
    const DrawCall& d = plan.passes[0].draws[static_cast<size_t>(i)];
    for (double u : {-1 + 2.0 * i / 8, -1 + 2.0 * (i + 1) / 8}) {
      for (double v : {-1.0, -0.4, 0.0, 0.7, 1.0}) {
        const Eigen::Vector2d ab = PlaneAbAlongRay(s, SurfacePointFromUv(s.monitor, {u, v}));
        const Eigen::Vector2d expected = DisplayPxFromUv(s.monitor, {u, v});
        EXPECT_LT((DisplayPxOfDraw(d, ab) - expected).norm(), 1e-6) << "strip " << i << " u " << u << " v " << v;
      }
    }
  }
}

// Between its edges a slice is linear where the surface is curved. The worst placement error over the pattern,
// computed from the plan alone, matches the reference figures of renderer_test.cc (numpy: 1.9 / 0.12 / 0.0075 px
// for 8 / 32 / 128 strips), i.e. it falls with the square of the strip count.
TEST(StripsPlan, PlacementErrorMatchesTheReferenceFigures) {
  const Scene s = Reference();
  const PatternCells& c = s.pattern.cells;
  const double a0 = c.top_left_mm.x(), a1 = a0 + c.width * c.cell_mm;
  const double b1 = c.top_left_mm.y(), b0 = b1 - c.height * c.cell_mm;
  for (const auto& [n, reference_px] : {std::pair(8, 1.9), std::pair(32, 0.12), std::pair(128, 0.0075)}) {
    MethodOptions o = Options(Method::kStrips);
    o.strips = n;
    const DrawPlan plan = Plan(s, o);
    double worst = 0;
    for (const DrawCall& d : plan.passes[0].draws) {
      for (int x = d.scissor.x; x < d.scissor.x + static_cast<int>(d.scissor.width); ++x) {
        for (int y = 0; y < 1440; y += 9) {
          const Eigen::Vector2d px(x, y);
          const Eigen::Vector2d ab =
              PlaneAbAlongRay(s, SurfacePointFromUv(s.monitor, UvFromDisplayPx(s.monitor, px)));
          if (ab.x() < a0 || ab.x() > a1 || ab.y() < b0 || ab.y() > b1) continue;  // outside the pattern
          worst = std::max(worst, (DisplayPxOfDraw(d, ab) - px).norm());
        }
      }
    }
    std::cout << n << " strips: worst placement " << worst << " px (reference " << reference_px << ")\n";
    EXPECT_NEAR(worst, reference_px, 0.15 * reference_px) << n << " strips";
  }
}

// warp: the first pass renders the off-axis frustum of core/off_axis_projection (thesis Eq 4.6, extents per 4.2.2)
// into an image s times the display plus 2 guard texels on each side; the frustum's extents map to the edges of
// the image's core.
TEST(WarpPlan, FirstPassIsTheOffAxisFrustumWithAGuardBand) {
  // Centred; above the screen's top edge, where 4.2.2 widens the vertical extents; off to the side.
  for (const Eigen::Vector3d& eye_from_centre :
       {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(0, 300, 700), Eigen::Vector3d(-250, -80, 500)}) {
    const Scene s = Reference(eye_from_centre);
    const OffAxisFrustum frustum = MakeOffAxisFrustum(s.monitor, s.eye);
    for (double scale : {1.0, 1.5, 0.5}) {
      SCOPED_TRACE(::testing::Message() << "eye " << eye_from_centre.transpose() << " scale " << scale);
      MethodOptions o = Options(Method::kWarp);
      o.warp_scale = scale;
      const DrawPlan plan = Plan(s, o);
      const double core_w = std::lround(scale * 3440), core_h = std::lround(scale * 1440);
      EXPECT_EQ(plan.intermediate.width, static_cast<uint32_t>(core_w) + 4);
      EXPECT_EQ(plan.intermediate.height, static_cast<uint32_t>(core_h) + 4);
      EXPECT_EQ(plan.params.warp[0], static_cast<float>(core_w + 4));
      EXPECT_EQ(plan.params.warp[1], static_cast<float>(core_h + 4));
      ASSERT_EQ(plan.passes.size(), 2u);
      const Pass& first = plan.passes[0];
      EXPECT_EQ(first.target, PassTarget::kIntermediate);
      EXPECT_EQ(first.pipeline, PipelineKind::kQuadLinear);
      ASSERT_EQ(first.draws.size(), 1u);
      const DrawCall& d = first.draws[0];
      EXPECT_EQ(d.viewport.width, core_w + 4);
      EXPECT_EQ(d.scissor.width, static_cast<uint32_t>(core_w) + 4);
      // Pattern points: the framebuffer position is the frustum's NDC placed in the core of the image.
      for (const Eigen::Vector2d& ab : {Eigen::Vector2d(0, 0), Eigen::Vector2d(-300, 100), Eigen::Vector2d(250, -90)}) {
        const Eigen::Vector3d ndc = frustum.NdcFromPoint(s.pattern.plane.PointInScreen(ab));
        const Eigen::Vector2d expected(2 + 0.5 * (ndc.x() + 1) * core_w, 2 + 0.5 * (1 - ndc.y()) * core_h);
        EXPECT_LT((Framebuffer(d.viewport, *d.clip_from_ab * Eigen::Vector4d(ab.x(), ab.y(), 0, 1)) - expected).norm(),
                  1e-6 * core_w);
      }
    }
  }
}

// warp through a grid: two triangles per cell; each vertex is at its display (u, v) and carries the texel
// coordinates (texel centres at integers) of its surface point in the first-pass image. From a centred eye the
// display's corners lie on the frustum's extents, so they sit 2 texels (the guard band) inside the image.
TEST(WarpPlan, GridVerticesCarryExactTexelCoordinates) {
  const Scene s = Reference();
  const OffAxisFrustum frustum = MakeOffAxisFrustum(s.monitor, s.eye);
  ASSERT_FALSE(frustum.vertical_extents_widened);
  MethodOptions o = Options(Method::kWarp);
  o.warp_grid_cols = 8;
  o.warp_grid_rows = 3;
  const DrawPlan plan = Plan(s, o);
  const Pass& warp = plan.passes.at(1);
  EXPECT_EQ(warp.pipeline, PipelineKind::kWarpGrid);
  ASSERT_EQ(warp.vertices.size(), 8u * 3 * 6 * 4);
  EXPECT_EQ(warp.draws.at(0).vertex_count, 8u * 3 * 6);
  const double w = plan.intermediate.width, h = plan.intermediate.height;
  for (size_t k = 0; k < warp.vertices.size(); k += 4) {
    const Eigen::Vector2d uv(warp.vertices[k], warp.vertices[k + 1]);
    const Eigen::Vector2d texel(warp.vertices[k + 2], warp.vertices[k + 3]);
    // On the grid: u in steps of 2/8, v in steps of 2/3.
    EXPECT_NEAR(std::remainder(uv.x() + 1, 0.25), 0, 1e-6);
    EXPECT_NEAR(std::remainder(uv.y() + 1, 2.0 / 3), 0, 1e-6);
    const Eigen::Vector3d ndc = frustum.NdcFromPoint(SurfacePointFromUv(s.monitor, uv));
    const Eigen::Vector2d expected(2 + 0.5 * (ndc.x() + 1) * (w - 4) - 0.5, 2 + 0.5 * (1 - ndc.y()) * (h - 4) - 0.5);
    EXPECT_LT((texel - expected).norm(), 1e-3) << uv.transpose();
    if (std::abs(uv.x()) > 0.999 && std::abs(uv.y()) > 0.999) {
      EXPECT_NEAR(texel.x(), uv.x() < 0 ? 1.5 : w - 2.5, 1e-3);
      EXPECT_NEAR(texel.y(), uv.y() < 0 ? 1.5 : h - 2.5, 1e-3);
    }
  }
  // Per fragment: one triangle over the display, no vertex data.
  const DrawPlan per_fragment = Plan(s, Options(Method::kWarp));
  EXPECT_EQ(per_fragment.passes.at(1).pipeline, PipelineKind::kWarpPerFragment);
  EXPECT_TRUE(per_fragment.passes.at(1).vertices.empty());
}

TEST(WarpPlan, RefusesAPatternInFrontOfTheNearPlane) {
  Scene s = Reference();
  s.pattern.plane.origin_in_screen.z() += s.monitor.sagitta_mm() + 20;  // nearer than the screen's corners
  try {
    Plan(s, Options(Method::kWarp));
    ADD_FAILURE() << "planned instead of refusing";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("in front of the plane of the screen's corners"));
  }
}

// mesh: the pattern's cell rectangle grown by one cell, cut into patches of at most mesh_patch_px display pixels
// at the screen centre; uniform levels above 32 split each patch (level 64 = 4 patches at level 32), and the
// patches are drawn in batches of at most kMaxTrianglesPerDraw triangles (2 level^2 each).
TEST(MeshPlan, PatchesTileThePatternAndBatchesStayUnderTheTriangleLimit) {
  const Scene s = Reference();
  const PatternCells& c = s.pattern.cells;
  const double a0 = c.top_left_mm.x() - c.cell_mm, a1 = c.top_left_mm.x() + (c.width + 1) * c.cell_mm;
  const double b1 = c.top_left_mm.y() + c.cell_mm, b0 = c.top_left_mm.y() - (c.height + 1) * c.cell_mm;
  struct Case {
    MeshSubdivision subdivision;
    int level;
    int split;
    double tess_level;
  };
  for (const Case& k : {Case{MeshSubdivision::kUniform, 16, 1, 16}, Case{MeshSubdivision::kUniform, 64, 2, 32},
                        Case{MeshSubdivision::kUniform, 48, 2, 24}, Case{MeshSubdivision::kExtended, 16, 1, 32}}) {
    SCOPED_TRACE(k.level);
    MethodOptions o = Options(Method::kMesh);
    o.mesh_subdivision = k.subdivision;
    o.mesh_level = k.level;
    o.mesh_patch_px = 256;
    const DrawPlan plan = Plan(s, o);
    ASSERT_EQ(plan.passes.size(), 1u);
    const Pass& mesh = plan.passes[0];
    EXPECT_EQ(mesh.pipeline, PipelineKind::kMesh);
    if (k.subdivision == MeshSubdivision::kUniform) {
      EXPECT_EQ(plan.params.mesh[1], k.tess_level);
    }
    const double patch_mm = 256 * s.monitor.pixel_pitch_mm() / k.split;
    const size_t na = static_cast<size_t>(std::ceil((a1 - a0) / patch_mm));
    const size_t nb = static_cast<size_t>(std::ceil((b1 - b0) / patch_mm));
    ASSERT_EQ(mesh.vertices.size(), na * nb * 8);
    double area = 0, lo_a = 1e9, hi_a = -1e9, lo_b = 1e9, hi_b = -1e9;
    for (size_t p = 0; p < na * nb; ++p) {
      const float* q = &mesh.vertices[8 * p];  // bottom-left, bottom-right, top-right, top-left
      EXPECT_EQ(q[0], q[6]);
      EXPECT_EQ(q[1], q[3]);
      EXPECT_EQ(q[2], q[4]);
      EXPECT_EQ(q[5], q[7]);
      EXPECT_LE(q[2] - q[0], patch_mm * (1 + 1e-6));
      EXPECT_LE(q[5] - q[1], patch_mm * (1 + 1e-6));
      area += static_cast<double>(q[2] - q[0]) * (q[5] - q[1]);
      lo_a = std::min<double>(lo_a, q[0]), hi_a = std::max<double>(hi_a, q[2]);
      lo_b = std::min<double>(lo_b, q[1]), hi_b = std::max<double>(hi_b, q[5]);
    }
    EXPECT_NEAR(lo_a, a0, 1e-3);
    EXPECT_NEAR(hi_a, a1, 1e-3);
    EXPECT_NEAR(lo_b, b0, 1e-3);
    EXPECT_NEAR(hi_b, b1, 1e-3);
    EXPECT_NEAR(area, (a1 - a0) * (b1 - b0), 1e-5 * (a1 - a0) * (b1 - b0));  // no gap, no overlap
    uint32_t next = 0;
    for (const DrawCall& d : mesh.draws) {
      EXPECT_EQ(d.first_vertex, next);
      EXPECT_EQ(d.vertex_count % 4, 0u);
      EXPECT_LE(d.vertex_count / 4 * 2 * k.tess_level * k.tess_level, kMaxTrianglesPerDraw);
      next += d.vertex_count;
    }
    EXPECT_EQ(next, na * nb * 4);
  }
}

// none: one pass, one draw: the panel taken as a flat W x H rectangle in the plane tangent at the screen centre.
// The default pattern lies in that plane, so each of its points is drawn where the flat rectangle has it,
// whatever the viewpoint.
TEST(NonePlan, DrawsThePatternPlaneAsAFlatPanel) {
  for (const Eigen::Vector3d& eye : {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(300, -100, 500)}) {
    const Scene s = Reference(eye);
    const DrawPlan plan = Plan(s, Options(Method::kNone));
    ASSERT_EQ(plan.passes.size(), 1u);
    ASSERT_EQ(plan.passes[0].draws.size(), 1u);
    const DrawCall& d = plan.passes[0].draws[0];
    EXPECT_EQ(d.viewport.width, 3440);
    EXPECT_EQ(d.scissor.width, 3440u);
    const double w = s.monitor.width_mm, h = s.monitor.height_mm;
    for (const Eigen::Vector2d& ab : {Eigen::Vector2d(0, 0), Eigen::Vector2d(-0.4 * w, 0.3 * h),
                                      Eigen::Vector2d(0.49 * w, -0.49 * h)}) {
      const Eigen::Vector2d expected((ab.x() / w + 0.5) * 3440 - 0.5, (0.5 - ab.y() / h) * 1440 - 0.5);
      EXPECT_LT((DisplayPxOfDraw(d, ab) - expected).norm(), 1e-6) << ab.transpose();
    }
  }
}

// exact: one draw of the strips that meet the pattern's display box, scissored to that box (every feature inside,
// with its 2 px); the strips (two triangles each) tile the box's columns, each a multiple of 4 columns wide but
// the display's last, and span the display's height.
TEST(ExactPlan, RayCastsThePatternBoxOnly) {
  const Scene s = Reference({200, 50, 650}, 0.1);
  MethodOptions o = Options(Method::kExact);
  const DrawPlan analytic = Plan(s, o);
  EXPECT_EQ(analytic.exact_supersample, 0);
  o.antialiasing = AntiAliasing::kSupersample;
  o.supersample = 4;
  const DrawPlan supersampled = Plan(s, o);
  EXPECT_EQ(supersampled.exact_supersample, 4);
  // Supersampled, the shader casts its rays itself: one strip, the display's width, the same scissor.
  ASSERT_EQ(supersampled.passes.at(0).draws.size(), 1u);
  EXPECT_EQ(supersampled.passes[0].draws[0].vertex_count, 6u);
  EXPECT_EQ(supersampled.passes[0].draws[0].scissor.x, analytic.passes.at(0).draws.at(0).scissor.x);
  EXPECT_EQ(supersampled.passes[0].draws[0].scissor.width, analytic.passes[0].draws[0].scissor.width);
  ASSERT_EQ(analytic.passes.size(), 1u);
  const Pass& pass = analytic.passes[0];
  EXPECT_EQ(pass.pipeline, PipelineKind::kExact);
  ASSERT_EQ(pass.draws.size(), 1u);
  const PixelRect& box = pass.draws[0].scissor;
  EXPECT_EQ(pass.draws[0].first_vertex, 0u);
  ASSERT_EQ(pass.vertices.size(), 9 * size_t{pass.draws[0].vertex_count});
  ASSERT_EQ(pass.draws[0].vertex_count % 6, 0u);
  const size_t strips = pass.draws[0].vertex_count / 6;
  ASSERT_GT(strips, 1u);
  const auto column = [&](size_t vertex) {  // framebuffer x of a vertex
    return std::lround(0.5 * (pass.vertices[9 * vertex] + 1) * s.monitor.width_px);
  };
  const auto row = [&](size_t vertex) { return std::lround(0.5 * (pass.vertices[9 * vertex + 1] + 1) * 1440); };
  for (size_t i = 0; i < strips; ++i) {
    const size_t v = 6 * i;
    const long c0 = column(v), c1 = column(v + 1);
    EXPECT_EQ(c0 % 4, 0) << "strip " << i;
    EXPECT_GT(c1, c0);
    if (i > 0) {
      EXPECT_EQ(c0, column(v - 5)) << "strip " << i;  // follows the previous strip
    } else {
      EXPECT_LE(c0, box.x);
    }
    if (i + 1 == strips) {
      EXPECT_GE(c1, box.x + static_cast<long>(box.width));
    }
    EXPECT_EQ(row(v), 0);
    EXPECT_EQ(row(v + 2), 1440);
  }
  EXPECT_GE(box.x, 0);
  EXPECT_LE(box.x + box.width, 3440u);
  EXPECT_LT(box.width, 3440u);  // the margin around the pattern is not ray cast
  int inside = 0;
  for (const Feature& f : s.pattern.features) {
    if (!f.visible) continue;
    EXPECT_GE(f.display_px->x(), box.x + 2);
    EXPECT_LE(f.display_px->x(), box.x + static_cast<double>(box.width) - 2);
    EXPECT_GE(f.display_px->y(), box.y + 2);
    EXPECT_LE(f.display_px->y(), box.y + static_cast<double>(box.height) - 2);
    ++inside;
  }
  EXPECT_EQ(inside, 15 * 5);
}

// exact: each pixel's ray from its strip's triangles (ExactDraws in draw_plan.cc: r = (n . d, x_p . d, y_p . d)
// linear across the strip plus the quadratic bow, t = exact[0] / r_0, (a, b) = exact[1..2] + t r_12) meets the
// plane where the exact ray does (PatternFromDisplayPx, double) to 2e-4 mm, at every column of the pattern's box
// and three rows, on the 34" 1000R panel from on and off its axis, a 49" 32:9 1000R and a 1800R panel, and a
// flat one (one strip). The quadratic's own error is bounded at 1e-5 px; what remains is the vertices' rounding
// to float.
TEST(ExactPlan, StripsReproduceEveryPixelsRay) {
  struct Case {
    Monitor monitor;
    Eigen::Vector3d eye_from_centre;
  };
  const std::vector<Case> cases = {{MonitorFromDiagonal("34 1000R", 3440, 1440, 34, 1000), {0, 0, 600}},
                                   {MonitorFromDiagonal("34 1000R", 3440, 1440, 34, 1000), {250, -80, 400}},
                                   {MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000), {0, 0, 500}},
                                   {MonitorFromDiagonal("27 1800R", 2560, 1440, 27, 1800), {60, 30, 700}},
                                   {MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0), {0, 0, 600}}};
  for (const Case& c : cases) {
    Scene s;
    s.monitor = c.monitor;
    s.eye = ScreenCentreInScreen(s.monitor) + c.eye_from_centre;
    s.pattern = BuildPattern(PatternSpec(), s.monitor, s.eye, TangentPlaneAtCentre(s.monitor));
    const DrawPlan plan = Plan(s, Options(Method::kExact));
    const Pass& pass = plan.passes.at(0);
    ASSERT_EQ(pass.draws.size(), 1u);
    const PixelRect& box = pass.draws[0].scissor;
    const int nx = s.monitor.width_px, ny = s.monitor.height_px;
    const auto at = [&](size_t vertex, int k) {
      return static_cast<double>(pass.vertices.at(9 * vertex + static_cast<size_t>(k)));
    };
    double worst = 0;
    int columns = 0;
    for (size_t v = 0; v < pass.vertices.size() / 9; v += 6) {
      // The strip's first triangle (c0, 0), (c1, 0), (c0, Ny) and second (c1, 0), (c1, Ny), (c0, Ny): both give
      // the attributes the same plane over the strip (they agree at its four corners, the vertices being exact).
      const double x0 = 0.5 * (at(v, 0) + 1) * nx, x1 = 0.5 * (at(v + 1, 0) + 1) * nx;
      EXPECT_DOUBLE_EQ(at(v, 5), 0.0);
      EXPECT_DOUBLE_EQ(at(v + 1, 5), 1.0);
      for (int k = 2; k < 5; ++k) {  // r at (c1, Ny) = r(c1, 0) + r(c0, Ny) - r(c0, 0): r is affine in the row
        EXPECT_NEAR(at(v + 4, k), at(v + 1, k) + at(v + 2, k) - at(v, k), 2e-5 * std::abs(at(v + 4, k)) + 1e-3);
      }
      for (int x = std::max(static_cast<int>(std::lround(x0)), box.x);
           x < std::min(static_cast<int>(std::lround(x1)), box.x + static_cast<int>(box.width)); ++x, ++columns) {
        for (const int y : {box.y, box.y + static_cast<int>(box.height) / 3, box.y + static_cast<int>(box.height) - 1}) {
          const double fx = (x + 0.5 - x0) / (x1 - x0), fy = (y + 0.5) / ny;
          const bool first = fx + fy <= 1;  // which triangle holds the pixel centre
          const auto lerp = [&](int k) {
            return first ? at(v, k) + fx * (at(v + 1, k) - at(v, k)) + fy * (at(v + 2, k) - at(v, k))
                         : at(v + 4, k) + (1 - fx) * (at(v + 5, k) - at(v + 4, k)) +
                               (1 - fy) * (at(v + 3, k) - at(v + 4, k));
          };
          const double u = lerp(5);
          Eigen::Vector3d r;
          for (int k = 0; k < 3; ++k) r[k] = lerp(2 + k) + 4 * u * (1 - u) * at(v, 6 + k);
          const double t = plan.params.exact[0] / r.x();
          const Eigen::Vector2d ab(plan.params.exact[1] + t * r.y(), plan.params.exact[2] + t * r.z());
          const auto truth = PatternFromDisplayPx(s.monitor, s.eye, s.pattern.plane, {x, y});
          ASSERT_TRUE(truth.has_value());
          worst = std::max(worst, (ab - *truth).norm());
        }
      }
    }
    EXPECT_EQ(columns, static_cast<int>(box.width)) << s.monitor.name;  // the strips cover the box
    EXPECT_LT(worst, 2e-4) << s.monitor.name;
    std::cout << s.monitor.name << ": " << pass.vertices.size() / 54 << " strips, worst |ab - exact| " << worst
              << " mm\n";
  }
}

// The shaders' inputs: surface tables at pixel edges and centres (centre frame), padded cell labels, clear colours.
TEST(DrawPlan, ShaderInputsDescribeTheSurfaceAndTheCells) {
  const Scene s = Reference();
  const DrawPlan plan = Plan(s, Options(Method::kExact));
  const double r = 1000, theta = s.monitor.half_sector_rad(), h = s.monitor.height_mm;
  ASSERT_EQ(plan.surface_xz.size(), 2u * (2 * 3440 + 1));
  ASSERT_EQ(plan.surface_y.size(), 2u * 1440 + 1);
  EXPECT_NEAR(plan.surface_xz[0], -r * std::sin(theta), 1e-3);          // left edge of the display
  EXPECT_NEAR(plan.surface_xz[1], r * (1 - std::cos(theta)), 1e-3);     // its depth behind the chord's ends
  EXPECT_NEAR(plan.surface_xz[2 * 3440], 0, 1e-6);                      // sample 3440: the display's centre
  EXPECT_NEAR(plan.surface_xz[4 * 3440], r * std::sin(theta), 1e-3);    // right edge
  EXPECT_NEAR(plan.surface_y[0], h / 2, 1e-4);                          // top edge
  EXPECT_NEAR(plan.surface_y[2 * 1440], -h / 2, 1e-4);                  // bottom edge
  const PatternCells& c = s.pattern.cells;
  ASSERT_EQ(plan.cells.size.width, static_cast<uint32_t>(c.width + 2));
  ASSERT_EQ(plan.cells.size.height, static_cast<uint32_t>(c.height + 2));
  const size_t w = plan.cells.size.width;
  for (int row = -1; row <= c.height; ++row) {
    for (int col = -1; col <= c.width; ++col) {
      const bool padding = row < 0 || col < 0 || row == c.height || col == c.width;
      const int expected = padding ? 2 : (c.Value(col, row) >= 128 ? 1 : 0);
      ASSERT_EQ(plan.cells.labels[static_cast<size_t>(row + 1) * w + static_cast<size_t>(col + 1)], expected);
    }
  }
  EXPECT_FLOAT_EQ(plan.passes[0].clear_colour[0], 128 / 255.0f);  // the surround's code value
  const DrawPlan coordinates = Plan(s, Options(Method::kExact), RenderOutput::kCoordinates);
  EXPECT_TRUE(std::isnan(coordinates.passes[0].clear_colour[0]));  // no plane point
}

TEST(DrawPlan, RefusesWhatTheMethodOrTheDeviceCannotDraw) {
  auto refusal = [](const Scene& s, const MethodOptions& o, const DeviceLimits& limits) -> std::string {
    try {
      Plan(s, o, RenderOutput::kShade, limits);
    } catch (const Error& e) {
      return e.what();
    }
    return "planned";
  };
  const Scene inside_chord = Reference({0, 0, 60});  // nearer than the plane of the corners: 180 deg
  EXPECT_THAT(refusal(inside_chord, Options(Method::kMesh), kLimits), HasSubstr("180 deg"));
  EXPECT_THAT(refusal(inside_chord, Options(Method::kWarp), kLimits), HasSubstr("180 deg"));
  const Scene s = Reference();
  EXPECT_THAT(refusal(s, Options(Method::kMesh), {16384, false, "x"}), HasSubstr("no tessellation shaders"));
  EXPECT_THAT(refusal(s, Options(Method::kExact), {2048, true, "small"}),
              HasSubstr("the display of 3440x1440 px exceeds the device's limit of 2048 px (small)"));
  MethodOptions big = Options(Method::kWarp);
  big.warp_scale = 4;
  EXPECT_THAT(refusal(s, big, {13763, true, "x"}), HasSubstr("the warp's first-pass image of 13764x5764 px"));
  EXPECT_EQ(refusal(s, big, {13764, true, "x"}), "planned");
}

}  // namespace
}  // namespace curvecheck
