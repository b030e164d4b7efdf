#version 450
// One triangle covering the viewport. It also writes location 0 (unused, zero) because warp.frag declares the
// distortion grid's texel coordinate there: every input the fragment stage declares must be written by the
// stage before it (Vulkan's interface matching; the Khronos validation layer flags it otherwise, see
// render_vulkan_validation in render/CMakeLists.txt). The per-fragment warp computes its texel itself.
layout(location = 0) noperspective out vec2 out_texel;

void main() {
  vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
  out_texel = vec2(0.0);
}
