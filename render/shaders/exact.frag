#version 450
#extension GL_GOOGLE_include_directive : require
// exact: every pixel casts its own ray (thesis 4.1) from the viewpoint through its point on the nominal
// surface and shows the pattern where the ray meets the plane. Analytic anti-aliasing integrates the pattern
// over the pixel's footprint (the box filter of footprint.glsl); supersampling averages n x n exact rays.
#include "common.glsl"
#include "footprint.glsl"

layout(constant_id = 2) const int kSupersample = 0;  // 0: analytic anti-aliasing; n: n x n rays per pixel

layout(location = 0) noperspective in vec3 in_ray;
layout(location = 1) noperspective in float in_u;
layout(location = 2) flat in vec3 in_bow;
layout(location = 0) out vec4 out_color;

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  // The ray to the pixel centre's surface point: r = (n . d, x_p . d, y_p . d), interpolated across its strip
  // with the strip's quadratic bow (render/draw_plan.cc ExactDraws: exact to 1e-5 px). It meets the plane at
  // t = n . (p0 - o) / (n . d); (a, b) are the offsets from p0 along the plane axes.
  // Supersampled, the plan draws one strip (no interpolated ray): the centre's ray from the column table.
  vec2 ab;
  if (kSupersample == 0) {
    vec3 r = in_ray + (4.0 * in_u * (1.0 - in_u)) * in_bow;
    float t = P.exact.x / r.x;
    ab = (t > 0.0 && !isinf(t)) ? P.exact.yz + t * r.yz : vec2(NaN());
  } else {
    vec2 xz = column_xz[2 * px.x + 1];  // the column table (double on the CPU); the height is linear in the row
    ab = PlaneAb(vec3(xz.x, (0.5 - gl_FragCoord.y / P.monitor.y) * P.monitor.w, xz.y));
  }
  if (OutputCoordinates()) {
    out_color = vec4(ab, 0.0, 1.0);
    return;
  }
  float value;
  if (kSupersample == 0) {
    // The footprint's Jacobian from the differences of the exact (a, b) within the 2 x 2 quad, as for the other
    // methods; `bench render`'s FLIP against ss16 (49" 1000R on axis: 0.0026 at 100 cm, 0.0034 at 25 cm) is what
    // the analytic Jacobian of the ray, used before the strips, gave.
    value = FootprintAverage(ab);
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
