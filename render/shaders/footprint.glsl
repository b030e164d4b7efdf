// Fragment shaders only (screen-space derivatives).

// Box filter of the pixel footprint estimated from the screen-space derivatives of (a, b): the footprint of
// a pixel is [ab - e, ab + e] with e = (|d ab/dx| + |d ab/dy|) / 2 (fine derivatives: differences within each
// 2 x 2 quad). Errors are of second order in the pixel size, which is what keeps edges unbiased.
float FootprintAverage(vec2 ab) {
  vec2 half_extent = 0.5 * (abs(dFdxFine(ab)) + abs(dFdyFine(ab)));
  return BoxAverage(ab - half_extent, ab + half_extent);
}
