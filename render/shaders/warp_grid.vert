#version 450
// warp through a distortion grid: vertices at display coordinates carry their exact texture coordinates in
// the first-pass image (computed on the CPU in double); the rasterizer interpolates them linearly.
layout(location = 0) in vec2 in_clip;
layout(location = 1) in vec2 in_texel;
layout(location = 0) noperspective out vec2 out_texel;
void main() {
  out_texel = in_texel;
  gl_Position = vec4(in_clip, 0.0, 1.0);
}
