#version 450
#extension GL_GOOGLE_include_directive : require
// mesh: each generated vertex is projected onto the cylinder and placed at its display position (thesis
// Eq 4.7, 4.8); clip coordinates are multiplied by the xz distance from the viewpoint to the vertex (Eq 4.9)
// so that the rasterizer interpolates (a, b) perspective-correctly.
#include "common.glsl"
#include "cylinder_projection.glsl"

layout(quads, equal_spacing, ccw) in;
layout(location = 0) in vec2 in_ab[];
layout(location = 0) out vec2 out_ab;

void main() {
  vec2 t = gl_TessCoord.xy;
  vec2 ab = mix(mix(in_ab[0], in_ab[1], t.x), mix(in_ab[3], in_ab[2], t.x), t.y);
  vec3 p = PlanePoint(ab);
  vec2 uv = ProjectToDisplayUv(p);
  float w = length((p - P.viewpoint.xyz).xz);
  out_ab = ab;
  gl_Position = vec4(uv * w, 0.5 * w, w);
}
