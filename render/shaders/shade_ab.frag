#version 450
#extension GL_GOOGLE_include_directive : require
// Shades interpolated plane coordinates (a, b), box-filtered over the pixel footprint (FootprintAverage), or
// writes (a, b) itself in coordinate mode.
#include "common.glsl"
#include "footprint.glsl"

layout(constant_id = 1) const int kLinearOutput = 0;  // 1 for the warp's first pass: the second pass encodes

layout(location = 0) in vec2 in_ab;
layout(location = 0) out vec4 out_color;

void main() {
  if (OutputCoordinates()) {
    out_color = vec4(in_ab, 0.0, 1.0);
    return;
  }
  float value = FootprintAverage(in_ab);
  out_color = kLinearOutput == 1 ? vec4(value) : Encode(value);
}
