#version 450
#extension GL_GOOGLE_include_directive : require
// exact: every pixel casts its own ray (thesis 4.1) from the viewpoint through its point on the nominal
// surface and shows the pattern where the ray meets the plane. Analytic anti-aliasing integrates the pattern
// over the pixel's footprint, whose Jacobian is computed analytically from the ray; supersampling averages
// n x n exact rays.
#include "common.glsl"
#include "footprint.glsl"

layout(constant_id = 2) const int kSupersample = 0;  // 0: analytic anti-aliasing; n: n x n rays per pixel

layout(location = 0) out vec4 out_color;

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  // Surface point of the pixel centre: x, z from the column table (exact, computed in double on the CPU); the
  // height is linear in the row, y = (1 - 2 (row + 0.5) / Ny) H / 2 = (0.5 - gl_FragCoord.y / Ny) H.
  vec2 xz = column_xz[2 * px.x + 1];
  vec3 s = vec3(xz.x, (0.5 - gl_FragCoord.y / P.monitor.y) * P.monitor.w, xz.y);
  // Ray o + t (s - o) meets the plane n . (p - p0) = 0; (a, b) are the offsets from p0 along the plane axes.
  vec3 d = s - P.viewpoint.xyz;
  float nd = dot(P.plane_n.xyz, d);
  float t = dot(P.plane_n.xyz, P.plane_origin.xyz - P.viewpoint.xyz) / nd;
  vec3 q = (P.viewpoint.xyz - P.plane_origin.xyz) + t * d;
  vec2 ab = (t > 0.0 && !isinf(t)) ? vec2(dot(q, P.plane_x.xyz), dot(q, P.plane_y.xyz)) : vec2(NaN());
  if (OutputCoordinates()) {
    out_color = vec4(ab, 0.0, 1.0);
    return;
  }
  float value;
  if (kSupersample == 0) {
    // Jacobian of ab per display pixel, analytically: dq/ds . v = t (v - (n . v)/(n . d) d) for a surface
    // motion v; one pixel right moves the surface point by pitch (cos phi, 0, sin phi) (phi its angle about the
    // axis, from x and z), one pixel down by (0, -H/Ny, 0).
    float k = P.monitor2.x, pitch = P.monitor.z / P.monitor.x;
    vec3 vx = pitch * vec3(1.0 - k * xz.y, 0.0, k * xz.x);  // (cos phi, sin phi) = (1 - k z, k x)
    vec3 vy = vec3(0.0, -P.monitor.w / P.monitor.y, 0.0);
    vec3 wx = t * (vx - dot(P.plane_n.xyz, vx) / nd * d), wy = t * (vy - dot(P.plane_n.xyz, vy) / nd * d);
    value = FootprintAverageJacobian(ab, vec2(dot(wx, P.plane_x.xyz), dot(wx, P.plane_y.xyz)),
                                     vec2(dot(wy, P.plane_x.xyz), dot(wy, P.plane_y.xyz)));
  } else {
    const int n = kSupersample;
    float sum = 0.0;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        vec2 sample_px = vec2(px) + (vec2(i, j) + 0.5) / float(n) - 0.5;
        sum += PointSample(PlaneAb(SurfacePoint(sample_px)));
      }
    }
    value = sum / float(n * n);
  }
  out_color = Encode(value);
}
