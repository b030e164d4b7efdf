#version 450
#extension GL_GOOGLE_include_directive : require
// mesh: tessellation levels per patch edge. Uniform: a fixed level. Perez et al.: the distance (display px)
// between the projected midpoint of the edge and the midpoint of its projected ends (thesis 4.3.2, Fig 4.7).
// Extended (thesis 4.3.2, Fig 4.8): also the quarter points, so that S-shaped edges are not judged straight,
// and interior points for the inner level (InnerLevel). The deviation of a subdivided edge falls with the square of the
// level, so the level is ceil(sqrt(deviation / tolerance)). Each edge's level depends only on its end points
// in a fixed order, so neighbouring patches agree and the mesh has no cracks.
#include "common.glsl"
#include "cylinder_projection.glsl"

layout(vertices = 4) out;

// Levels above 32 make lavapipe drop primitives (render/renderer.cc, kMaxTessLevel).
const float kMaxLevel = 32.0;
layout(location = 0) in vec2 in_ab[];
layout(location = 0) out vec2 out_ab[];

float EdgeLevel(vec2 e0, vec2 e1) {
  if (P.mesh.x < 0.5) return P.mesh.y;
  if (e1.x < e0.x || (e1.x == e0.x && e1.y < e0.y)) { vec2 t = e0; e0 = e1; e1 = t; }
  vec2 p0 = DisplayPxFromUv(ProjectToDisplayUv(PlanePoint(e0)));
  vec2 p1 = DisplayPxFromUv(ProjectToDisplayUv(PlanePoint(e1)));
  float deviation = 0.0;
  int samples = P.mesh.x < 1.5 ? 1 : 3;
  for (int i = 1; i <= samples; ++i) {
    float f = float(i) / float(samples + 1);
    vec2 p = DisplayPxFromUv(ProjectToDisplayUv(PlanePoint(mix(e0, e1, f))));
    deviation = max(deviation, distance(p, mix(p0, p1, f)));
  }
  if (isnan(deviation)) return kMaxLevel;
  return clamp(ceil(sqrt(deviation / P.mesh.z)), 1.0, kMaxLevel);
}

// Inner level (extended heuristic): the deviation of interior points (the centre and the quarter points of
// both diagonals) from the bilinear interpolation of the projected corners. On quad patches a diagonal through
// the optical axis (thesis Fig 4.8) runs inside the patch, where no edge sample sees it.
float InnerLevel(float edges) {
  if (P.mesh.x < 1.5) return edges;
  vec2 q[4];
  for (int i = 0; i < 4; ++i) q[i] = DisplayPxFromUv(ProjectToDisplayUv(PlanePoint(in_ab[i])));
  const vec2 samples[5] = vec2[5](vec2(0.5), vec2(0.25), vec2(0.75), vec2(0.25, 0.75), vec2(0.75, 0.25));
  float deviation = 0.0;
  for (int i = 0; i < 5; ++i) {
    vec2 t = samples[i];
    vec2 ab = mix(mix(in_ab[0], in_ab[1], t.x), mix(in_ab[3], in_ab[2], t.x), t.y);
    vec2 linear = mix(mix(q[0], q[1], t.x), mix(q[3], q[2], t.x), t.y);
    deviation = max(deviation, distance(DisplayPxFromUv(ProjectToDisplayUv(PlanePoint(ab))), linear));
  }
  if (isnan(deviation)) return kMaxLevel;
  return max(edges, clamp(ceil(sqrt(deviation / P.mesh.z)), 1.0, kMaxLevel));
}

void main() {
  out_ab[gl_InvocationID] = in_ab[gl_InvocationID];
  if (gl_InvocationID == 0) {
    // Quad domain: outer[0] is the edge u = 0 (corners 0-3), [1] v = 0 (0-1), [2] u = 1 (1-2), [3] v = 1 (3-2).
    float l0 = EdgeLevel(in_ab[0], in_ab[3]);
    float l1 = EdgeLevel(in_ab[0], in_ab[1]);
    float l2 = EdgeLevel(in_ab[1], in_ab[2]);
    float l3 = EdgeLevel(in_ab[3], in_ab[2]);
    gl_TessLevelOuter[0] = l0;
    gl_TessLevelOuter[1] = l1;
    gl_TessLevelOuter[2] = l2;
    gl_TessLevelOuter[3] = l3;
    float inner = InnerLevel(max(max(l0, l1), max(l2, l3)));
    gl_TessLevelInner[0] = inner;
    gl_TessLevelInner[1] = inner;
  }
}
