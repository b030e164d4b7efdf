#include "pattern/texture.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace curvecheck {
namespace {

PatternCells Outline() {
  PatternCells o;
  o.cell_mm = 10;
  o.top_left_mm = {-200, 50};
  o.width = 40;
  o.height = 10;
  return o;
}

TEST(Texture, CoversTheOutlineWithBinaryCellsAndFineDetail) {
  const PatternCells t = MakeTextureCells(Outline(), 0.5, 3);
  EXPECT_EQ(t.width, 800);
  EXPECT_EQ(t.height, 200);
  EXPECT_EQ(t.top_left_mm, Outline().top_left_mm);
  int white = 0, changes = 0;
  for (int r = 0; r < t.height; ++r) {
    for (int c = 0; c < t.width; ++c) {
      ASSERT_TRUE(t.Value(c, r) == 0 || t.Value(c, r) == 255);
      white += t.Value(c, r) == 255;
      if (c > 0) changes += t.Value(c, r) != t.Value(c - 1, r);
    }
  }
  const double n = t.width * t.height;
  // Neither black nor white dominates, and edges are dense: a 1/f texture alone changes at a few per cent of
  // neighbouring pairs; the 1-cell strokes of the text add many more.
  EXPECT_GT(white / n, 0.3);
  EXPECT_LT(white / n, 0.8);
  EXPECT_GT(changes / n, 0.05);
  // Deterministic for a seed, different for another.
  EXPECT_EQ(MakeTextureCells(Outline(), 0.5, 3).values, t.values);
  EXPECT_NE(MakeTextureCells(Outline(), 0.5, 4).values, t.values);
}

TEST(Texture, RefusesBadCellSizes) {
  EXPECT_THROW(MakeTextureCells(Outline(), 0, 1), Error);
  EXPECT_THROW(MakeTextureCells(Outline(), 50, 1), Error);     // 8 x 2 cells
  EXPECT_THROW(MakeTextureCells(Outline(), 0.01, 1), Error);   // 40000 cells across
}

}  // namespace
}  // namespace curvecheck
