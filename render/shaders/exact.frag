#version 450
#extension GL_GOOGLE_include_directive : require
// exact: every pixel casts its own ray (thesis 4.1) from the viewpoint through its point on the nominal
// surface and shows the pattern where the ray meets the plane. Analytic anti-aliasing integrates the pattern
// over the pixel's footprint (FootprintAverage, from the exact rays of the 2 x 2 quad); supersampling
// averages n x n exact rays.
#include "common.glsl"
#include "footprint.glsl"

layout(constant_id = 2) const int kSupersample = 0;  // 0: analytic anti-aliasing; n: n x n rays per pixel

layout(location = 0) out vec4 out_color;

vec3 TablePoint(int column_sample, int row_sample) {
  vec2 xz = column_xz[column_sample];
  return vec3(xz.x, row_y[row_sample], xz.y);
}

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  vec2 ab = PlaneAb(TablePoint(2 * px.x + 1, 2 * px.y + 1));
  if (OutputCoordinates()) {
    out_color = vec4(ab, 0.0, 1.0);
    return;
  }
  float value;
  if (kSupersample == 0) {
    value = FootprintAverage(ab);
  } else {
    const int n = kSupersample;
    float sum = 0.0;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        vec2 d = vec2(px) + (vec2(i, j) + 0.5) / float(n) - 0.5;
        sum += PointSample(PlaneAb(SurfacePoint(d)));
      }
    }
    value = sum / float(n * n);
  }
  out_color = Encode(value);
}
