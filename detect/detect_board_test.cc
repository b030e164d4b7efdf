// The orientation rule of checkerboards (detect.h) on drawn boards with known corner names: square colours where
// the board's parity decides, the upright rule where it does not, refusal where neither does.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <random>

#include "detect/detect_board.h"

namespace curvecheck::detect_internal {
namespace {

struct DrawnBoard {
  cv::Mat image;
  CornerGrid grid;                // in a scrambled order (as a detector might return it)
  std::vector<int> true_index;    // per grid point: the pattern's k = row * (cols - 1) + col
};

// A board of cols x rows squares of `square` px (top-left square black), rotated by roll_deg (clockwise on
// the image) about the image centre, drawn on white. The grid is returned transposed and reversed when
// `scramble` is set, as a detector that started at another corner would return it.
DrawnBoard Draw(int cols, int rows, double square, double roll_deg, bool scramble) {
  const int size = 900;
  DrawnBoard b;
  b.image = cv::Mat(size, size, CV_8U, cv::Scalar(230));
  const double a = roll_deg * std::numbers::pi / 180;
  const auto place = [&](double col, double row) {  // board coordinates (squares) -> image
    const double x = (col - cols / 2.0) * square, y = (row - rows / 2.0) * square;
    return cv::Point2d(size / 2.0 + std::cos(a) * x - std::sin(a) * y, size / 2.0 + std::sin(a) * x + std::cos(a) * y);
  };
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 != 0) continue;
      std::vector<cv::Point> poly;
      for (const auto& [dc, dr] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
        const cv::Point2d p = place(c + dc, r + dr);
        poly.emplace_back(static_cast<int>(std::lround(p.x * 16)), static_cast<int>(std::lround(p.y * 16)));
      }
      cv::fillConvexPoly(b.image, poly, cv::Scalar(20), cv::LINE_AA, 4);
    }
  }
  const int nc = cols - 1, nr = rows - 1;
  if (!scramble) {
    b.grid.width = nc;
    b.grid.height = nr;
    for (int r = 0; r < nr; ++r) {
      for (int c = 0; c < nc; ++c) {
        b.grid.px.push_back(place(c + 1, r + 1));
        b.true_index.push_back(r * nc + c);
      }
    }
  } else {  // transposed and both directions reversed: still unmirrored
    b.grid.width = nr;
    b.grid.height = nc;
    for (int c = 0; c < nc; ++c) {
      for (int r = nr - 1; r >= 0; --r) {
        b.grid.px.push_back(place(c + 1, r + 1));
        b.true_index.push_back(r * nc + c);
      }
    }
  }
  b.grid.quality.assign(b.grid.px.size(), 1.0);
  return b;
}

// The same board seen in a mirror (the image flipped left to right, the corners with it): the names stay those
// of the physical corners, so a correct orientation names it mirrored.
DrawnBoard Mirror(DrawnBoard b) {
  cv::flip(b.image, b.image, 1);
  for (cv::Point2d& p : b.grid.px) p.x = b.image.cols - 1 - p.x;
  return b;
}

// 16 x 5 squares: cols + rows odd, so the colours tell 0 from 180 deg at any roll; the only other orientation
// they leave is mirrored (the board's mirror image has the colours of the board turned by 180 deg), and it is
// taken only where it is upright and the unmirrored one is not (MirroredViews).
TEST(BoardOrientation, ColoursDecideANonSquareBoardWithOddParityAtAnyRoll) {
  for (double roll : {0.0, 30.0, 89.0, 135.0, -139.0, -100.0}) {
    for (bool scramble : {false, true}) {
      const DrawnBoard b = Draw(16, 5, 45, roll, scramble);
      const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 5, 40);
      ASSERT_EQ(o.failure, "") << roll;
      EXPECT_EQ(o.corner_index, b.true_index) << "roll " << roll << " scramble " << scramble;
      EXPECT_NE(o.note.find("square colours"), std::string::npos) << o.note;
      EXPECT_FALSE(o.mirrored) << roll;
    }
  }
}

// Mirrored views are named mirrored where the colours (or, between a mirrored and an unmirrored candidate, the
// upright rule) say so; a board that is its own mirror image is named unmirrored.
TEST(BoardOrientation, MirroredViews) {
  // 16 x 6 (even x even): no turn of the board has the colours of its mirror image, at any roll. (Which of the
  // two mirrored namings the colours leave: the more upright one, so at 180 deg the board is named upright.)
  for (double roll : {0.0, 90.0, 180.0, -60.0}) {
    const DrawnBoard b = Mirror(Draw(16, 6, 45, roll, true));
    const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 6, 40);
    ASSERT_EQ(o.failure, "") << roll;
    EXPECT_TRUE(o.mirrored) << roll;
    EXPECT_TRUE(o.handedness_from_colours) << roll;
    if (roll == 0 || roll == -60) {
      EXPECT_EQ(o.corner_index, b.true_index) << roll;
    }
    EXPECT_NE(o.note.find("mirrored views only"), std::string::npos) << o.note;
  }
  // 16 x 5 upright in a mirror: the colours leave it and the board turned by 180 deg; the upright rule names it.
  for (double roll : {0.0, 25.0, -35.0}) {
    const DrawnBoard b = Mirror(Draw(16, 5, 45, roll, true));
    const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 5, 40);
    ASSERT_EQ(o.failure, "") << roll;
    EXPECT_TRUE(o.mirrored) << roll;
    EXPECT_FALSE(o.handedness_from_colours) << roll;
    EXPECT_EQ(o.corner_index, b.true_index) << roll;
    EXPECT_EQ(o.unmirrored_alternative, fmt::format("an unmirrored photo with the board turned by {:.0f} deg",
                                                    180 - std::abs(roll)));
  }
  // ... so the same board photographed upside down, unmirrored, reads as mirrored and upright (the two cannot
  // be told apart: the upright rule's assumption).
  const DrawnBoard turned = Draw(16, 5, 45, 180, false);
  const BoardOrientation t = ResolveBoardOrientation(turned.grid, turned.image, 16, 5, 40);
  ASSERT_EQ(t.failure, "");
  EXPECT_TRUE(t.mirrored);
  for (size_t i = 0; i < t.corner_index.size(); ++i) {  // named as the board upright, flipped top to bottom
    const int k = turned.true_index[i];
    EXPECT_EQ(t.corner_index[i], (3 - k / 15) * 15 + k % 15);
  }
  // 10 x 10 upright in a mirror: the colours fit its mirror image upright, or unmirrored and turned by 90 deg.
  const DrawnBoard square = Mirror(Draw(10, 10, 60, 10, true));
  const BoardOrientation q = ResolveBoardOrientation(square.grid, square.image, 10, 10, 40);
  ASSERT_EQ(q.failure, "");
  EXPECT_TRUE(q.mirrored);
  EXPECT_EQ(q.corner_index, square.true_index);
  // 15 x 5 and 11 x 11 (odd x odd) are their own mirror images: named unmirrored, mirrored or not.
  for (int cols : {15, 11}) {
    const int rows = cols == 15 ? 5 : 11;
    for (bool mirror : {false, true}) {
      const DrawnBoard b = mirror ? Mirror(Draw(cols, rows, 45, 5, true)) : Draw(cols, rows, 45, 5, true);
      const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, cols, rows, 40);
      ASSERT_EQ(o.failure, "") << cols << " " << mirror;
      EXPECT_FALSE(o.mirrored) << cols << " " << mirror;
      if (!mirror) {
        EXPECT_EQ(o.corner_index, b.true_index) << cols;
      }
    }
  }
}

TEST(BoardOrientation, AffineHandedness) {
  // An upright view: pattern a right, b up -> image x right, y down; det < 0. Mirrored: > 0.
  std::vector<Eigen::Vector2d> plane, upright, mirrored, tilted;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) {
      plane.emplace_back(10.0 * i, 10.0 * j);
      upright.emplace_back(100 + 5.0 * i, 200 - 5.0 * j);
      mirrored.emplace_back(-upright.back().x(), upright.back().y());
      tilted.emplace_back(100 + 2.5 * i, 200 - 5.0 * j);  // foreshortened to half across
    }
  }
  EXPECT_NEAR(AffineHandedness(plane, upright), -1, 1e-12);
  EXPECT_NEAR(AffineHandedness(plane, mirrored), 1, 1e-12);
  EXPECT_NEAR(AffineHandedness(plane, tilted), -0.5, 1e-12);
  EXPECT_TRUE(std::isnan(AffineHandedness({plane[0], plane[1]}, {upright[0], upright[1]})));
  EXPECT_TRUE(std::isnan(AffineHandedness({{0, 0}, {1, 1}, {2, 2}}, {{0, 0}, {1, 0}, {0, 1}})));  // collinear
}

// 16 x 6 squares: a 180 deg turn keeps the colours, so the upright rule decides, and refuses past 40 deg.
TEST(BoardOrientation, UprightRuleDecidesWhereColoursCannot) {
  for (double roll : {0.0, 25.0, -39.0}) {
    const DrawnBoard b = Draw(16, 6, 45, roll, true);
    const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 6, 40);
    ASSERT_EQ(o.failure, "") << roll;
    EXPECT_EQ(o.corner_index, b.true_index) << roll;
    EXPECT_NE(o.note.find("upright rule"), std::string::npos) << o.note;
  }
  for (double roll : {60.0, 90.0, -120.0}) {
    const DrawnBoard b = Draw(16, 6, 45, roll, false);
    const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 6, 40);
    EXPECT_TRUE(o.failure.starts_with("ambiguous orientation")) << roll << ": " << o.failure;
  }
  // Upside down: indistinguishable from upright by construction, named as upright (the rule's assumption).
  const DrawnBoard b = Draw(16, 6, 45, 180, false);
  const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 6, 40);
  ASSERT_EQ(o.failure, "");
  for (size_t i = 0; i < o.corner_index.size(); ++i) EXPECT_EQ(o.corner_index[i], 74 - b.true_index[i]);
}

// Square boards: 10 x 10 squares (even) - the colours tell 90 deg turns apart, the upright rule 180 deg;
// 11 x 11 (odd) - the upright rule alone. Both refuse at 45 deg, where two orientations are equally upright.
TEST(BoardOrientation, SquareBoards) {
  for (double roll : {0.0, 30.0, -35.0}) {
    for (int n : {10, 11}) {
      const DrawnBoard b = Draw(n, n, 60, roll, true);
      const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, n, n, 40);
      ASSERT_EQ(o.failure, "") << n << " " << roll;
      EXPECT_EQ(o.corner_index, b.true_index) << n << " " << roll;
    }
  }
  for (int n : {10, 11}) {
    const DrawnBoard b = Draw(n, n, 60, 45, false);
    EXPECT_TRUE(ResolveBoardOrientation(b.grid, b.image, n, n, 40).failure.starts_with("ambiguous orientation")) << n;
  }
  // 10 x 10 at 90 deg: the colours leave 90 and 270 deg, both 90 deg from upright, and the board's mirror
  // images across its diagonals, one of them upright: named mirrored (MirroredViews; DetectFeatures refuses it).
  const DrawnBoard b = Draw(10, 10, 60, 90, false);
  const BoardOrientation turned = ResolveBoardOrientation(b.grid, b.image, 10, 10, 40);
  ASSERT_EQ(turned.failure, "");
  EXPECT_TRUE(turned.mirrored);
  EXPECT_EQ(turned.unmirrored_alternative, "an unmirrored photo with the board turned by 90 deg");
  // 11 x 11 at 90 deg looks exactly like an upright 11 x 11 board: named as upright (the rule's assumption).
  const DrawnBoard odd = Draw(11, 11, 60, 90, false);
  const BoardOrientation o = ResolveBoardOrientation(odd.grid, odd.image, 11, 11, 40);
  ASSERT_EQ(o.failure, "");
  EXPECT_NE(o.corner_index, odd.true_index);
}

// An inverted photo (white squares where black ones belong) of a colour-decisive board.
TEST(BoardOrientation, InvertedColoursAreRefused) {
  DrawnBoard b = Draw(16, 5, 45, 0, false);
  b.image = 250 - b.image;
  const BoardOrientation o = ResolveBoardOrientation(b.grid, b.image, 16, 5, 40);
  // 16 x 5 inverted has the colours of the board turned by 180 deg, and of its mirror image: named as the
  // upright one of the two, mirrored (the names are consistent with the colours, which is all a photo can tell;
  // DetectFeatures refuses it as mirrored).
  ASSERT_EQ(o.failure, "");
  EXPECT_TRUE(o.mirrored);
  for (size_t i = 0; i < o.corner_index.size(); ++i) {
    EXPECT_EQ(o.corner_index[i], b.true_index[i] / 15 * 15 + 14 - b.true_index[i] % 15);
  }
  // A grid whose rows run right to left (index order only; the view is not mirrored) is named correctly.
  CornerGrid reversed = b.grid;
  std::vector<int> truth = b.true_index;
  for (int j = 0; j < reversed.height; ++j) {
    std::reverse(reversed.px.begin() + j * reversed.width, reversed.px.begin() + (j + 1) * reversed.width);
    std::reverse(truth.begin() + j * reversed.width, truth.begin() + (j + 1) * reversed.width);
  }
  const DrawnBoard upright = Draw(16, 5, 45, 0, false);
  EXPECT_EQ(ResolveBoardOrientation(reversed, upright.image, 16, 5, 40).corner_index, truth);
}

// A drawn board (8 x 5 squares of 80 px; white 230, black 20) whose white squares are crossed by dark bands (11 px
// in every 29 px, at 70 deg to the image's x: a display's aliased gaps), rolled 0, 10 and 30 deg: the deficit is
// the bands' share of the white times their depth (and about 0 without them); opencv-sb finds no board on the
// banded photo and finds it on a closing of it, every corner within 1 px of the drawn one.
TEST(GapDeficit, DarkBandsAreMeasuredAndTheBoardIsFoundOnAClosing) {
  for (const double roll : {0.0, 10.0, 30.0}) {
    const DrawnBoard clean = Draw(8, 5, 80, roll, false);
    cv::Mat banded = clean.image.clone();
    const double a = 70 * std::numbers::pi / 180;
    int in_band = 0, white = 0;
    for (int r = 0; r < banded.rows; ++r) {
      for (int c = 0; c < banded.cols; ++c) {
        if (banded.at<uint8_t>(r, c) < 225) continue;  // the white squares' inside and the margin
        ++white;
        if (std::fmod(std::cos(a) * c + std::sin(a) * r, 29.0) < 11.0) banded.at<uint8_t>(r, c) = 20, ++in_band;
      }
    }
    const double expected = (230.0 - 20.0) / 230.0 * in_band / white;
    const GapDeficit none = MeasureGapDeficit(clean.image, clean.grid, 80);
    EXPECT_TRUE(none.measured);
    EXPECT_EQ(none.size_px, kGapMeasureSizePx);
    EXPECT_LT(none.deficit, 0.02) << roll;
    const GapDeficit gaps = MeasureGapDeficit(banded, clean.grid, 80);
    EXPECT_NEAR(gaps.deficit, expected, 0.15 * expected) << roll << ": bands over " << in_band << " of " << white;
    const GapDeficit whole = MeasureGapDeficit(banded, cv::Rect(0, 0, banded.cols, banded.rows));
    EXPECT_NEAR(whole.deficit, expected, 0.15 * expected) << roll;
    const auto search = [](const cv::Mat& image) { return RunOpenCvSb(image, cv::Size(7, 4), false); };
    EXPECT_FALSE(search(banded)) << roll;
    cv::Mat found_on;
    int size = 0;
    const std::optional<CornerGrid> grid = SearchOnClosings(banded, search, found_on, size);
    ASSERT_TRUE(grid) << roll;
    EXPECT_GE(size, 5) << roll;
    EXPECT_EQ(found_on.size(), banded.size());
    ASSERT_EQ(grid->px.size(), clean.grid.px.size());
    // Every found corner near a drawn one (the grid's order is the detector's).
    double worst = 0;
    for (const cv::Point2d& p : grid->px) {
      double nearest = 1e9;
      for (const cv::Point2d& q : clean.grid.px) nearest = std::min(nearest, cv::norm(p - q));
      worst = std::max(worst, nearest);
    }
    std::cout << fmt::format("roll {:g} deg: deficit {:.4f} (bands: {:.4f}; whole photo {:.4f}); found on a {} px "
                             "closing, corners within {:.2f} px\n",
                             roll, gaps.deficit, expected, whole.deficit, size, worst);
    EXPECT_LT(worst, 1.0) << roll;
  }
}

// A perspective view of a curved board has almost no third differences along its rows and columns; independent
// errors of sigma per coordinate are read back as sigma (within 10% over 31 x 8 corners).
TEST(GridRoughness, SmoothGridsAreNearZeroAndNoiseIsReadBack) {
  CornerGrid g;
  g.width = 31;
  g.height = 8;
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      // A cylinder of radius 1000 mm seen from 1500 mm off its axis at 20 deg: x = R sin(a), z = R (1 - cos(a)).
      const double a = (i - 15) * 37.5 / 1000, y = (j - 3.5) * 37.5;
      const double x = 1000 * std::sin(a), z = 1000 * (1 - std::cos(a)) + 1500;
      const double c = std::cos(0.35), s = std::sin(0.35);
      const double xc = c * x + s * (z - 1500), zc = -s * x + c * (z - 1500) + 1500;
      g.px.emplace_back(960 + 1400 * xc / zc, 540 + 1400 * y / zc);
    }
  }
  EXPECT_LT(GridRoughnessPx(g), 0.002);
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0, 0.3);
  for (cv::Point2d& p : g.px) p += cv::Point2d(noise(rng), noise(rng));
  EXPECT_NEAR(GridRoughnessPx(g), 0.3, 0.03);
  CornerGrid tiny;
  tiny.width = 3;
  tiny.height = 3;
  tiny.px.assign(9, cv::Point2d(0, 0));
  EXPECT_TRUE(std::isnan(GridRoughnessPx(tiny)));
}

// The refinement's noise response is an estimate from a few draws: its stated standard uncertainty (response_u_px)
// is the spread of the response over other seeds. A drawn board (12 x 9 squares of 40 px, rolled 10 deg) with
// Gaussian noise of 6 gray levels, its corners refined, then measured with 16 seeds (4 draws each).
TEST(RefinementNoise, StatedUncertaintyIsTheSpreadOverSeeds) {
  DrawnBoard b = Draw(12, 9, 40, 10, false);
  cv::Mat noisy;
  b.image.convertTo(noisy, CV_32F);
  cv::GaussianBlur(noisy, noisy, cv::Size(0, 0), 1.0);
  cv::Mat n(noisy.size(), CV_32F);
  cv::RNG(11).fill(n, cv::RNG::NORMAL, 0.0, 6.0);
  noisy += n;
  RefineXCorners(noisy, 0, b.grid);
  const RefinementNoise base = MeasureSquareNoise(noisy, b.grid);
  ASSERT_TRUE(base.measured);
  EXPECT_NEAR(base.black_sd, 6.0, 0.6);
  std::vector<double> response, stated;
  for (uint64_t seed = 1; seed <= 16; ++seed) {
    RefinementNoise r = base;
    MeasureRefinementNoise(noisy, b.grid, 0, 4, seed, r);
    ASSERT_EQ(r.corners, 88);
    response.push_back(r.response_px);
    stated.push_back(r.response_u_px);
  }
  const double mean = std::accumulate(response.begin(), response.end(), 0.0) / 16;
  double var = 0;
  for (double v : response) var += (v - mean) * (v - mean) / 15;
  const double spread = std::sqrt(var), u = std::accumulate(stated.begin(), stated.end(), 0.0) / 16;
  std::cout << "response " << mean << " px; spread over 16 seeds " << spread << " px, stated u " << u << " px\n";
  // 16 seeds know the spread to about 18% (1 / sqrt(2 x 15)): about -2.2 and +2.8 of that.
  EXPECT_GT(spread / u, 0.6);
  EXPECT_LT(spread / u, 1.5);
  EXPECT_LT(u / mean, 0.1);
}

}  // namespace
}  // namespace curvecheck::detect_internal
