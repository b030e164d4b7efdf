#version 450
#extension GL_GOOGLE_include_directive : require
// warp, second pass: each display pixel samples the first-pass image (the pattern in linear off-axis
// perspective, thesis Eq 4.6) where its surface point projects, with a bilinear or Catmull-Rom cubic filter
// (cf. thesis Listing 4.1, written here with explicit taps). Texture coordinates come per fragment (exact,
// from the projection of the surface point) or from the distortion grid.
#include "common.glsl"

layout(constant_id = 0) const int kPerFragment = 1;
layout(constant_id = 3) const int kCubic = 1;  // 0: bilinear
layout(location = 0) noperspective in vec2 in_texel;
layout(location = 0) out vec4 out_color;

vec4 Tap(ivec2 t) {
  ivec2 size = ivec2(P.warp.xy);
  return texelFetch(intermediate, clamp(t, ivec2(0), size - 1), 0);
}

vec4 CubicWeights(float f) {  // Catmull-Rom
  float f2 = f * f, f3 = f2 * f;
  return vec4(-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f, 0.5 * f3 - 0.5 * f2);
}

void main() {
  vec2 texel;  // continuous texel coordinates, texel centres at integers
  if (kPerFragment == 1) {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 xz = column_xz[2 * px.x + 1];
    vec4 clip = P.clip_from_centre * vec4(xz.x, row_y[2 * px.y + 1], xz.y, 1.0);
    vec2 ndc = clip.xy / clip.w;
    texel = (ndc * 0.5 + 0.5) * P.warp.xy - 0.5;
  } else {
    texel = in_texel;
  }
  vec2 base = floor(texel);
  vec2 f = texel - base;
  ivec2 b = ivec2(base);
  vec4 value;
  if (kCubic == 0) {
    value = mix(mix(Tap(b), Tap(b + ivec2(1, 0)), f.x), mix(Tap(b + ivec2(0, 1)), Tap(b + ivec2(1, 1)), f.x), f.y);
  } else {
    vec4 wx = CubicWeights(f.x), wy = CubicWeights(f.y);
    value = vec4(0.0);
    for (int j = 0; j < 4; ++j) {
      vec4 row = wx.x * Tap(b + ivec2(-1, j - 1)) + wx.y * Tap(b + ivec2(0, j - 1)) + wx.z * Tap(b + ivec2(1, j - 1)) +
                 wx.w * Tap(b + ivec2(2, j - 1));
      value += wy[j] * row;
    }
  }
  out_color = OutputCoordinates() ? vec4(value.xy, 0.0, 1.0) : Encode(value.x);
}
