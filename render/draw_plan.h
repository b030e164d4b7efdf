// What the renderer draws for one frame, as a plain value: every correction method (architecture.md,
// "Correction methods") is a list of passes, each with its pipeline, vertex data, draws (viewport, scissor,
// push constant) and target, plus the shader inputs they share (uniform block, surface tables, cell labels).
// MakeDrawPlan computes it on the CPU, in double, with no Vulkan type; render/renderer.cc records any plan into
// Vulkan command buffers the same way. Tests check a plan's geometry without a device (draw_plan_test.cc).
//
// Coordinates: framebuffer pixels have their top-left corner at (0, 0) (display pixel (i, j) is framebuffer
// [i, i + 1) x [j, j + 1)); clip space is Vulkan's (y down, depth 0..1); the centre frame is the screen frame
// translated so that the screen centre is its origin (shaders/common.glsl).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/monitor.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {

// What a frame produces.
enum class RenderOutput {
  kShade,        // 8-bit display code values (Renderer::Render)
  kCoordinates,  // the plane coordinates (a, b) each pixel shows (Renderer::RenderCoordinates)
};

// Texel formats of the images a plan draws into.
enum class TexelFormat {
  kShade8,       // one 8-bit UNORM channel: display code values
  kLinear32,     // one float: linear light (the warp's first pass when shading)
  kCoordinates,  // two floats: plane coordinates (a, b) in mm, NaN where the plane is not shown
};

// The shader programs (render/shaders), each a pipeline; the vertex data of a pass is laid out as its pipeline
// reads it.
enum class PipelineKind {
  kExact,            // exact.vert + exact.frag: per-pixel ray cast over strips, 9 floats per vertex (ExactDraws)
  kQuad,             // project_quad.vert + shade_ab.frag: a rectangle of the plane, (a, b) per vertex, strip of 4
  kQuadLinear,       // the same, writing linear light (the warp's first pass when shading)
  kWarpPerFragment,  // fullscreen.vert + warp.frag: resamples the first pass at exact texel coordinates
  kWarpGrid,         // warp_grid.vert + warp.frag: triangles of a display grid, (u, v, texel x, texel y) per vertex
  kMesh,             // mesh.vert/.tesc/.tese + shade_ab.frag: quad patches, (a, b) per corner, 4 per patch
};

// Where a pass draws.
enum class PassTarget {
  kIntermediate,  // the warp's first-pass image, sampled by later passes (binding 4)
  kDisplay,       // the display-sized image that is read back
};

// std140 layout of the Params block in shaders/common.glsl (binding 0); the comments there say what each holds.
struct alignas(16) ShaderParams {
  float monitor[4];
  float monitor2[4];
  float viewpoint[4];
  float plane_origin[4];
  float plane_x[4];
  float plane_y[4];
  float plane_n[4];
  float cells[4];
  int32_t cells_size[4];
  float clip_from_centre[16];  // column-major
  float warp[4];
  float mesh[4];
  float exact[4];
};

struct ImageSize {
  uint32_t width = 1, height = 1;
};

// A framebuffer rectangle [x, x + width) x [y, y + height), px.
struct PixelRect {
  int32_t x = 0, y = 0;
  uint32_t width = 0, height = 0;
};

// The viewport transform: clip x -1..1 maps to framebuffer x .. x + width (y likewise); depth 0..1.
struct Viewport {
  double x = 0, y = 0, width = 0, height = 0;
};

struct DrawCall {
  uint32_t first_vertex = 0;
  uint32_t vertex_count = 0;
  Viewport viewport;
  PixelRect scissor;
  // kQuad and kQuadLinear: the push constant, a projection from plane coordinates (a, b, 0, 1) to clip space.
  std::optional<Eigen::Matrix4d> clip_from_ab;
};

struct Pass {
  PipelineKind pipeline = PipelineKind::kExact;
  PassTarget target = PassTarget::kDisplay;
  std::array<float, 4> clear_colour{};  // the whole target is cleared to this first
  std::vector<float> vertices;          // the vertex buffer; empty if the vertex shader makes its own
  std::vector<DrawCall> draws;
};

// Pattern cells as labels (0 black, 1 white, 2 surround) with one cell of surround padding on each side, so that
// the shaders need no bounds checks (shaders/common.glsl); binding 3.
struct CellLabels {
  ImageSize size;
  std::vector<uint8_t> labels;  // row-major, size.width * size.height
};

struct DrawPlan {
  ImageSize display;  // the monitor's resolution
  TexelFormat display_format = TexelFormat::kShade8;
  // The warp's first pass (1 x 1 and never drawn by the other methods, which still bind it).
  ImageSize intermediate;
  TexelFormat intermediate_format = TexelFormat::kLinear32;
  ShaderParams params{};
  // The surface at display pixel edges and centres, in the centre frame, exact in double and rounded once:
  // for k = 0 .. 2N, sample k sits at display coordinate k/2 - 0.5 (shaders/common.glsl, bindings 1 and 2).
  std::vector<float> surface_xz;  // (x, z) per column sample, 2 (2 Nx + 1) floats
  std::vector<float> surface_y;   // y per row sample, 2 Ny + 1 floats
  CellLabels cells;
  // Specialization constants: samples per axis of the exact method's supersampling (0: analytic box filter);
  // Catmull-Rom cubic resampling of the warp (else bilinear).
  int exact_supersample = 0;
  bool warp_cubic = true;
  std::vector<Pass> passes;  // drawn in order
};

// What the device can do, as far as a plan depends on it.
struct DeviceLimits {
  uint64_t max_image_px = 16384;  // largest image and framebuffer edge
  bool tessellation = true;       // tessellation shaders (the mesh method)
  std::string device_name;        // for messages
};

// The plan of one frame of `options.method`. Throws Error if the options are out of range, or if the method
// cannot render this view correctly (it refuses rather than draw a wrong image: an invalid viewpoint, a field of
// view of 180 deg or more for warp and mesh, a strip seen edge-on, a pattern in front of the warp's near plane),
// or if an image would exceed `limits`.
DrawPlan MakeDrawPlan(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen, const Pattern& pattern,
                      const RenderOptions& options, RenderOutput output, const DeviceLimits& limits);

// A 4x4 matrix as 16 floats, column-major (GLSL's mat4 in a uniform block or push constant).
std::array<float, 16> ColumnMajorFloats(const Eigen::Matrix4d& m);

// Number of segments per patch edge above which the tessellator is not asked (shaders/mesh.tesc clamps to it):
// lavapipe drops primitives beyond it, so a higher uniform level splits the patches instead.
constexpr int kMaxTessLevel = 32;
// lavapipe (Mesa 22.3) silently drops primitives when one tessellated draw emits more than about 1e5 triangles
// (measured: 138k triangles in one draw left 91% of a 2560x720 frame undrawn; 61k drew every pixel). Mesh
// patches are therefore drawn in batches of at most this many triangles.
constexpr int kMaxTrianglesPerDraw = 32768;

}  // namespace curvecheck
