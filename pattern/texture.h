// A textured plane for judging image quality (issue 21): resampling blur shows on fine detail, not on the large
// squares of a checkerboard. The texture is binary and made of the same square cells every pattern is made of
// (PatternCells), so every renderer and method draws it exactly as it draws a checkerboard: no new shader path,
// and the exact method's anti-aliasing integrates it like any pattern.
//
// Content: thresholded 1/f ("pink") noise, a sum of value-noise octaves with spacings 1, 2, 4, ... 256 cells and
// amplitudes proportional to the spacing (the amplitude spectrum of natural images falls as 1/f), so its outlines
// have detail at every scale down to one cell; and blocks of text-like strokes (rows of random glyphs of 1-cell
// strokes on a 5 x 7 cell grid, dark on light) covering about a quarter of the area.
#pragma once

#include <cstdint>

#include "pattern/pattern.h"

namespace curvecheck {

// Cells of cell_mm over the rectangle of `outline` (its top-left corner, and its extent rounded down to whole
// cells), filled with the texture drawn from `seed` (the same seed and size give the same cells). Throws Error if
// cell_mm is not positive or the texture would have fewer than 16 or more than 16384 cells along an axis.
PatternCells MakeTextureCells(const PatternCells& outline, double cell_mm, uint32_t seed);

}  // namespace curvecheck
