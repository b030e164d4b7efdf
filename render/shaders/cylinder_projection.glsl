// The cylindrical projection of the mesh method (thesis 4.3.1): a point of the plane is moved along its ray
// from the viewpoint onto the screen surface (Eq 4.7; here the exit point of the ray from the cylinder, valid
// for viewpoints inside and outside it), and placed at its display position (Eq 4.8: x from the angle about
// the axis, y from the height). Written in the centre frame, where the cylinder is kappa (x^2 + z^2) = 2 z.

vec3 PlanePoint(vec2 ab) { return P.plane_origin.xyz + ab.x * P.plane_x.xyz + ab.y * P.plane_y.xyz; }

// Display (u, v) in -1..1 of the ray from the viewpoint toward p; NaN if the ray misses the surface.
vec2 ProjectToDisplayUv(vec3 p) {
  vec3 o = P.viewpoint.xyz;
  vec3 d = p - o;
  float k = P.monitor2.x;
  float a = k * (d.x * d.x + d.z * d.z);
  float b = 2.0 * (k * (o.x * d.x + o.z * d.z) - d.z);
  float c = k * (o.x * o.x + o.z * o.z) - 2.0 * o.z;
  float t;
  if (a == 0.0) {
    t = -c / b;
  } else {
    float disc = b * b - 4.0 * a * c;
    if (disc < 0.0) return vec2(NaN());
    float sq = sqrt(disc);
    t = b >= 0.0 ? c / (-0.5 * (b + sq)) : (-0.5 * (b - sq)) / a;
  }
  vec3 h = o + t * d;
  float s = k == 0.0 ? h.x : atan(k * h.x, 1.0 - k * h.z) / k;
  return vec2(2.0 * s / P.monitor.z, -2.0 * h.y / P.monitor.w);
}

vec2 DisplayPxFromUv(vec2 uv) { return (uv + 1.0) * 0.5 * P.monitor.xy - 0.5; }
