#include "pattern/texture.h"

#include <fmt/format.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/error.h"

namespace curvecheck {

PatternCells MakeTextureCells(const PatternCells& outline, double cell_mm, uint32_t seed) {
  if (!(cell_mm > 0) || !std::isfinite(cell_mm))
    throw Error("texture", fmt::format("cell size {} mm is not positive", cell_mm), "give a positive cell size");
  PatternCells cells;
  cells.cell_mm = cell_mm;
  cells.top_left_mm = outline.top_left_mm;
  const double width_mm = outline.width * outline.cell_mm, height_mm = outline.height * outline.cell_mm;
  const double w = std::floor(width_mm / cell_mm), h = std::floor(height_mm / cell_mm);
  if (w < 16 || h < 16 || w > 16384 || h > 16384)
    throw Error("texture",
                fmt::format("{:g} x {:g} mm in cells of {:g} mm is {:g} x {:g} cells", width_mm, height_mm, cell_mm, w,
                            h),
                "use a cell size that gives 16 to 16384 cells along each axis");
  cells.width = static_cast<int>(w);
  cells.height = static_cast<int>(h);

  // 1/f noise: octaves of bilinear value noise, spacing s cells, amplitude s.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uniform(-1, 1);
  std::vector<float> noise(static_cast<size_t>(cells.width) * cells.height, 0.0f);
  for (int spacing = 1; spacing <= 256; spacing *= 2) {
    const int gw = cells.width / spacing + 2, gh = cells.height / spacing + 2;
    std::vector<float> grid(static_cast<size_t>(gw) * gh);
    for (float& g : grid) g = uniform(rng);
    for (int r = 0; r < cells.height; ++r) {
      const float fy = static_cast<float>(r) / spacing;
      const int y0 = static_cast<int>(fy);
      const float ty = fy - y0;
      for (int c = 0; c < cells.width; ++c) {
        const float fx = static_cast<float>(c) / spacing;
        const int x0 = static_cast<int>(fx);
        const float tx = fx - x0;
        auto at = [&](int x, int y) { return grid[static_cast<size_t>(y) * gw + x]; };
        const float top = at(x0, y0) + tx * (at(x0 + 1, y0) - at(x0, y0));
        const float bottom = at(x0, y0 + 1) + tx * (at(x0 + 1, y0 + 1) - at(x0, y0 + 1));
        noise[static_cast<size_t>(r) * cells.width + c] += spacing * (top + ty * (bottom - top));
      }
    }
  }
  cells.values.resize(noise.size());
  for (size_t i = 0; i < noise.size(); ++i) cells.values[i] = noise[i] > 0 ? 255 : 0;

  // Text blocks: light background, rows of glyphs 5 x 7 cells with 1-cell strokes, 1 cell between glyphs, 3
  // between rows; each glyph is a random subset of the strokes of a 5 x 7 "segment" font (verticals at the left,
  // middle and right column, horizontals at the top, middle and bottom row, two diagonals).
  std::uniform_int_distribution<int> bits(1, (1 << 10) - 1);
  auto set = [&](int c, int r, uint8_t v) {
    if (c >= 0 && r >= 0 && c < cells.width && r < cells.height) cells.values[static_cast<size_t>(r) * cells.width + c] = v;
  };
  const int block_w = std::max(24, cells.width / 5), block_h = std::max(20, cells.height / 5);
  std::uniform_int_distribution<int> bx(0, std::max(0, cells.width - block_w)), by(0, std::max(0, cells.height - block_h));
  const int blocks = std::max(1, static_cast<int>(std::lround(0.25 * cells.width * cells.height /
                                                              (static_cast<double>(block_w) * block_h))));
  for (int k = 0; k < blocks; ++k) {
    const int x0 = bx(rng), y0 = by(rng);
    for (int r = y0; r < y0 + block_h; ++r)
      for (int c = x0; c < x0 + block_w; ++c) set(c, r, 255);
    for (int gy = y0 + 2; gy + 7 <= y0 + block_h - 2; gy += 10) {
      for (int gx = x0 + 2; gx + 5 <= x0 + block_w - 2; gx += 6) {
        const int b = bits(rng);
        for (int i = 0; i < 7; ++i) {
          if (b & 1) set(gx, gy + i, 0);
          if (b & 2) set(gx + 2, gy + i, 0);
          if (b & 4) set(gx + 4, gy + i, 0);
          if (b & 64) set(gx + (i * 4) / 6, gy + i, 0);
          if (b & 128) set(gx + 4 - (i * 4) / 6, gy + i, 0);
        }
        for (int i = 0; i < 5; ++i) {
          if (b & 8) set(gx + i, gy, 0);
          if (b & 16) set(gx + i, gy + 3, 0);
          if (b & 32) set(gx + i, gy + 6, 0);
        }
      }
    }
  }
  return cells;
}

}  // namespace curvecheck
