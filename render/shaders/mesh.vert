#version 450
// mesh: patch corners in plane coordinates, passed on to the tessellator.
layout(location = 0) in vec2 in_ab;
layout(location = 0) out vec2 out_ab;
void main() { out_ab = in_ab; }
