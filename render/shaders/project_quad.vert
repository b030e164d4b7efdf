#version 450
// The pattern's rectangle, drawn with one 4x4 projection from plane coordinates (a, b, 0, 1) to clip space:
// the uncorrected linear perspective (none), one strip of the piecewise perspective (strips), or the
// off-axis first pass of warp. Perspective-correct interpolation carries (a, b) to the fragments.
layout(location = 0) in vec2 in_ab;
layout(location = 0) out vec2 out_ab;
layout(push_constant) uniform Push { mat4 clip_from_ab; } push;
void main() {
  out_ab = in_ab;
  gl_Position = push.clip_from_ab * vec4(in_ab, 0.0, 1.0);
}
