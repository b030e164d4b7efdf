// Shared declarations of the curvecheck render shaders. Geometry is expressed in the "centre frame": the screen
// frame translated so that the screen centre is the origin (core/screen_geometry.cc), which keeps every
// coordinate small for float precision. Units: mm.

layout(std140, set = 0, binding = 0) uniform Params {
  vec4 monitor;          // Nx, Ny, W (arc length), H
  vec4 monitor2;         // kappa (1/R, 0 flat), display gamma, surround (linear light), unused
  vec4 viewpoint;        // xyz, centre frame
  vec4 plane_origin;     // xyz, centre frame
  vec4 plane_x;          // unit
  vec4 plane_y;          // unit
  vec4 plane_n;          // unit, x cross y
  vec4 cells;            // cell_mm, a of the left edge, b of the top edge, unused
  ivec4 cells_size;      // width, height (without padding), unused, unused
  mat4 clip_from_centre; // warp: the off-axis frustum of the first pass (Vulkan clip space, y down)
  vec4 warp;             // intermediate width, height
  vec4 mesh;             // subdivision (0 uniform, 1 perez, 2 extended), uniform level, tolerance px
  vec4 exact;            // n . (plane_origin - viewpoint); (viewpoint - plane_origin) . plane_x, . plane_y; unused
} P;

// Display-pixel tables, computed in double on the CPU: for k = 0 .. 2N, sample k sits at display coordinate
// k/2 - 0.5, i.e. the left/top edge of pixel i is k = 2i, its centre 2i + 1, its right/bottom edge 2i + 2.
layout(std430, set = 0, binding = 1) readonly buffer Columns { vec2 column_xz[]; };  // surface x, z per column sample
layout(std430, set = 0, binding = 2) readonly buffer Rows { float row_y[]; };        // surface y per row sample

layout(set = 0, binding = 3) uniform usampler2D cell_texture;  // R8_UINT labels 0 black, 1 white, 2 surround;
                                                               // one surround cell of padding on each side
layout(set = 0, binding = 4) uniform sampler2D intermediate;   // warp: first-pass image; texelFetch only

float NaN() { return uintBitsToFloat(0x7fc00000u); }

// Specialization constants (set per pipeline, so that unused paths are compiled out: CPU rasterizers execute
// both sides of divergent branches).
layout(constant_id = 4) const int kCoordinates = 0;  // 1: write plane coordinates (a, b) instead of shading
bool OutputCoordinates() { return kCoordinates == 1; }

// Pattern-plane coordinates (a, b) of the point where the ray from the viewpoint through s (centre frame)
// meets the plane; NaN if it does not meet it in front of the viewpoint.
vec2 PlaneAb(vec3 s) {
  vec3 d = s - P.viewpoint.xyz;
  float denom = dot(P.plane_n.xyz, d);
  float t = dot(P.plane_n.xyz, P.plane_origin.xyz - P.viewpoint.xyz) / denom;
  if (!(t > 0.0) || isinf(t)) return vec2(NaN());
  vec3 q = (P.viewpoint.xyz - P.plane_origin.xyz) + t * d;
  return vec2(dot(q, P.plane_x.xyz), dot(q, P.plane_y.xyz));
}

float Sinc(float x) { return abs(x) < 1e-3 ? 1.0 - x * x / 6.0 : sin(x) / x; }

// Surface point (centre frame) at display coordinates (x, y) (pixel centres at integers), thesis Eq 4.1
// written as in core/screen_geometry.cc.
vec3 SurfacePoint(vec2 display) {
  float u = 2.0 * (display.x + 0.5) / P.monitor.x - 1.0;
  float v = 2.0 * (display.y + 0.5) / P.monitor.y - 1.0;
  float s = 0.5 * u * P.monitor.z;
  float phi = P.monitor2.x * s;
  float h = Sinc(0.5 * phi);
  return vec3(s * Sinc(phi), -0.5 * v * P.monitor.w, s * 0.5 * phi * h * h);
}

vec4 LabelToLinear(uvec4 label) {
  return mix(vec4(label), vec4(P.monitor2.z), equal(label, uvec4(2u)));
}

// Linear-light value of cell (col, row); the surround outside the grid (clamping reaches the padding).
float CellValue(ivec2 c) {
  ivec2 size = textureSize(cell_texture, 0);
  return LabelToLinear(uvec4(texelFetch(cell_texture, clamp(c + 1, ivec2(0), size - 1), 0).r)).x;
}

// Cell coordinates (col, row) of plane coordinates (a, b).
vec2 CellCoords(vec2 ab) { return vec2(ab.x - P.cells.y, P.cells.z - ab.y) / P.cells.x; }

float PointSample(vec2 ab) {
  if (isnan(ab.x)) return P.monitor2.z;
  return CellValue(ivec2(floor(CellCoords(ab))));
}

// Mean linear value of the 2 x 2 cells whose top-left cell is i0 (cell coordinates), weighted by the shares
// `first` of the first column and row. Branch-free on purpose: CPU rasterizers (lavapipe) execute both sides
// of divergent branches. The four cells come from one gather; the clamp-to-edge sampler reaches the surround
// padding beyond the grid.
float Gather2x2(vec2 i0, vec2 first) {
  // Gather at the corner shared by the four cells (texel coordinates include the padding of one cell).
  vec2 corner = (i0 + 2.0) / vec2(textureSize(cell_texture, 0));
  // Components: x = (i0, i0+1 row), y = (i0+1, i0+1 row), z = (i0+1, i0 row), w = (i0, i0 row).
  vec4 v = LabelToLinear(textureGather(cell_texture, corner, 0));
  float top = mix(v.z, v.w, first.x);
  float bottom = mix(v.y, v.x, first.x);
  return mix(bottom, top, first.y);
}

// Code value for the display: linear^(1/gamma); black and white need no power.
vec4 Encode(float linear) {
  float v = clamp(linear, 0.0, 1.0);
  if (v > 0.0 && v < 1.0) v = pow(v, 1.0 / P.monitor2.y);
  return vec4(vec3(v), 1.0);
}
