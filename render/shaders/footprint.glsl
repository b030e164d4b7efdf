// Fragment shaders only (screen-space derivatives).

// Share of a pixel footprint that lies below t along one axis (cell units, t measured from the footprint's
// centre). The footprint is the pixel square mapped by the local Jacobian, a parallelogram; its extent along an
// axis is the sum of two boxes of widths p = |d/dx| and q = |d/dy|, so its density is a trapezoid and the share is
// the trapezoid's CDF: quadratic ramps of length min(p, q), linear in between. With q = 0 it is the plain box.
// Branch-free (all pieces computed, then selected).
float TrapezoidCdf(float t, float p, float q) {
  float a = max(min(p, q), 1e-12), b = max(max(p, q), 1e-12);
  float h = 0.5 * (a + b), m = 0.5 * (b - a);
  float rising = (t + h) * (t + h) / (2.0 * a * b);
  float middle = a / (2.0 * b) + (t + m) / b;
  float falling = 1.0 - (h - t) * (h - t) / (2.0 * a * b);
  float f = t < -m ? rising : (t <= m ? middle : falling);
  return clamp(t <= -h ? 0.0 : (t >= h ? 1.0 : f), 0.0, 1.0);
}

// Mean linear value of the pattern over the pixel's footprint around plane coordinates ab, given the Jacobian
// of ab per display pixel (columns d ab/dx, d ab/dy). The weights of the 2 x 2 cells around the footprint come
// from TrapezoidCdf per axis (exact for a parallelogram footprint crossing one cell edge per axis; separable
// approximation at cell corners). Footprints wider than one cell (a pattern finer than the display resolves)
// are scaled down to one cell.
float FootprintAverageJacobian(vec2 ab, vec2 dab_dx, vec2 dab_dy) {
  vec2 c = CellCoords(ab);
  vec2 p = abs(vec2(dab_dx.x, -dab_dx.y)) / P.cells.x, q = abs(vec2(dab_dy.x, -dab_dy.y)) / P.cells.x;
  vec2 width = p + q;
  vec2 shrink = 1.0 / max(width, vec2(1.0));  // keep the footprint within one cell per axis
  p *= shrink;
  q *= shrink;
  vec2 i0 = floor(c - 0.5 * (p + q));
  vec2 edge = i0 + 1.0 - c;  // the cell edge between the two columns / rows, relative to the centre
  vec2 first = vec2(TrapezoidCdf(edge.x, p.x, q.x), TrapezoidCdf(edge.y, p.y, q.y));
  float value = Gather2x2(i0, first);
  return any(isnan(ab)) ? P.monitor2.z : value;
}

// The same with the Jacobian from the fine screen-space derivatives (differences within each 2 x 2 quad), for
// methods whose (a, b) come from the rasterizer.
float FootprintAverage(vec2 ab) { return FootprintAverageJacobian(ab, dFdxFine(ab), dFdyFine(ab)); }
