#version 450
// exact: the vertices of the display's strips (render/draw_plan.cc ExactDraws): r = (n . d, x_p . d, y_p . d) of
// the ray d to the surface at the vertex, linear across the strip, u = 0 .. 1 across it, and the strip's bow (the
// quadratic term of r along its arc), the same at its six vertices.
layout(location = 0) in vec2 in_clip;
layout(location = 1) in vec3 in_ray;
layout(location = 2) in float in_u;
layout(location = 3) in vec3 in_bow;
layout(location = 0) noperspective out vec3 out_ray;
layout(location = 1) noperspective out float out_u;
layout(location = 2) flat out vec3 out_bow;

void main() {
  gl_Position = vec4(in_clip, 0.0, 1.0);
  out_ray = in_ray;
  out_u = in_u;
  out_bow = in_bow;
}
