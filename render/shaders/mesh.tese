#version 450
#extension GL_GOOGLE_include_directive : require
// mesh: each generated vertex is projected onto the cylinder and placed at its display position (thesis
// Eq 4.7, 4.8); clip coordinates are multiplied by a perspective weight (Eq 4.9, generalized below) so that
// the rasterizer interpolates (a, b) perspective-correctly.
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
  // Perspective weight: the vertex's depth from the viewpoint along the surface normal where its ray meets the
  // screen. For a flat screen this is the z depth, which makes the interpolation exact (the mapping is then a
  // homography); for a viewpoint on the cylinder axis it is the xz distance of thesis Eq 4.9.
  float phi = P.monitor2.x * 0.5 * uv.x * P.monitor.z;
  float w = dot(P.viewpoint.xyz - p, vec3(-sin(phi), 0.0, cos(phi)));
  out_ab = ab;
  gl_Position = vec4(uv * w, 0.5 * w, w);
}
