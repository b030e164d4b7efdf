#include "pattern/pattern.h"

#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/common/zarray.h>
#include <apriltag/tag36h11.h>
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>

#include "core/config.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;
using ::testing::HasSubstr;

Monitor Curved49() { return MonitorFromDiagonal("49", 5120, 1440, 49, 1000); }
Monitor Flat27() { return MonitorFromDiagonal("27", 2560, 1440, 27, 0); }
const Eigen::Vector3d kCentred(0, 0, 500);      // on the axis, 1.5 m in front of the 1000R screen centre
const Eigen::Vector3d kOffAxis(350, 120, 150);  // inside the cylinder, right of and above the centre

using testing::MessageOf;

// How far the outline of the cell grid stays inside the margin rectangle of the display, in display pixels:
// the smallest distance over `samples_per_edge` points per edge. 0 = touching, negative = crossing.
double OutlineSlackPx(const Pattern& p, const Monitor& m, const Eigen::Vector3d& viewpoint,
                      int samples_per_edge) {
  const PatternCells& c = p.cells;
  const Eigen::Vector2d corners[4] = {c.CornerMm(0, 0), c.CornerMm(c.width, 0), c.CornerMm(c.width, c.height),
                                      c.CornerMm(0, c.height)};
  const double mx = p.spec.margin * m.width_px, my = p.spec.margin * m.height_px;
  double slack = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 4; ++e) {
    for (int i = 0; i < samples_per_edge; ++i) {
      const double t = static_cast<double>(i) / samples_per_edge;
      const auto px =
          DisplayPxFromPattern(m, viewpoint, p.plane, corners[e] + t * (corners[(e + 1) % 4] - corners[e]));
      if (!px) return -std::numeric_limits<double>::infinity();
      slack = std::min({slack, px->x() + 0.5 - mx, m.width_px - 0.5 - px->x() - mx, px->y() + 0.5 - my,
                        m.height_px - 0.5 - px->y() - my});
    }
  }
  return slack;
}

// --- AprilTag detection of rendered cells (libapriltag's own detector) ---

struct Detection {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners_px;  // image pixel coordinates, pixel centres at integers
};

// Draws the cells at px_per_cell image pixels per cell with pad_px of mid grey around them (the renderer's
// surround), and runs the tag36h11 detector at full resolution. With refine_edges the detector moves the
// corners of such hard, unblurred edges by a constant -1/8 px in x and y (measured); without it the fitted
// quads land on the cell edges to 1e-4 px.
std::vector<Detection> DetectTags(const PatternCells& cells, int px_per_cell, int pad_px, bool refine_edges) {
  const int w = cells.width * px_per_cell + 2 * pad_px, h = cells.height * px_per_cell + 2 * pad_px;
  std::unique_ptr<image_u8_t, void (*)(image_u8_t*)> im(image_u8_create(w, h), image_u8_destroy);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int col = (x - pad_px) / px_per_cell, row = (y - pad_px) / px_per_cell;
      const bool inside = x >= pad_px && y >= pad_px && col < cells.width && row < cells.height;
      im->buf[y * im->stride + x] = inside ? cells.Value(col, row) : 128;
    }
  }
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> fam(tag36h11_create(), tag36h11_destroy);
  std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> det(apriltag_detector_create(),
                                                                           apriltag_detector_destroy);
  apriltag_detector_add_family(det.get(), fam.get());
  det->quad_decimate = 1;
  det->nthreads = 1;
  det->refine_edges = refine_edges;
  zarray_t* found = apriltag_detector_detect(det.get(), im.get());
  std::vector<Detection> out;
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(found, i, &d);
    Detection r;
    r.id = d->id;
    // AprilTag's image coordinates put the centre of pixel (i, j) at (i + 0.5, j + 0.5); ours at (i, j).
    for (int k = 0; k < 4; ++k)
      r.corners_px[k] = Eigen::Vector2d(d->p[k][0], d->p[k][1]) - Eigen::Vector2d(0.5, 0.5);
    out.push_back(r);
  }
  apriltag_detections_destroy(found);
  return out;
}

// Image position (pixel centres at integers) of a pattern point in the image DetectTags draws.
Eigen::Vector2d ImagePx(const PatternCells& cells, const Eigen::Vector2d& pattern_mm, int px_per_cell,
                        int pad_px) {
  const Eigen::Vector2d cell((pattern_mm.x() - cells.top_left_mm.x()) / cells.cell_mm,
                             (cells.top_left_mm.y() - pattern_mm.y()) / cells.cell_mm);
  return Eigen::Vector2d::Constant(pad_px - 0.5) + px_per_cell * cell;
}

// Every tag of the pattern is detected once with its id, and its corners are the t<id>.<k> features in
// order, to tol_px. Returns the worst corner error in image pixels.
double ExpectTagsDecode(const Pattern& p, const std::vector<int>& expected_ids, bool refine_edges = false,
                        double tol_px = 0.01) {
  constexpr int kPxPerCell = 8, kPad = 24;
  std::map<std::string, Eigen::Vector2d> feature_mm;
  for (const Feature& f : p.features) feature_mm[f.id] = f.pattern_mm;
  const std::vector<Detection> dets = DetectTags(p.cells, kPxPerCell, kPad, refine_edges);
  std::vector<int> ids;
  double worst_px = 0;
  for (const Detection& d : dets) {
    ids.push_back(d.id);
    for (int k = 0; k < 4; ++k) {
      const std::string id = fmt::format("t{}.{}", d.id, k);
      EXPECT_EQ(feature_mm.count(id), 1u) << id;
      if (feature_mm.count(id) == 0) continue;
      const Eigen::Vector2d expected = ImagePx(p.cells, feature_mm[id], kPxPerCell, kPad);
      EXPECT_THAT(d.corners_px[k], EigenNear(expected, tol_px)) << id;
      worst_px = std::max(worst_px, (d.corners_px[k] - expected).norm());
    }
  }
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, expected_ids);
  return worst_px;
}

// The cells of each tag (with its 1-cell white border) equal libapriltag's own drawing of the code.
void ExpectTagsMatchLibapriltag(const Pattern& p, const std::map<int, Eigen::Vector2i>& tag_top_left_cell) {
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> fam(tag36h11_create(), tag36h11_destroy);
  for (const auto& [id, tl] : tag_top_left_cell) {
    std::unique_ptr<image_u8_t, void (*)(image_u8_t*)> im(apriltag_to_image(fam.get(), id), image_u8_destroy);
    ASSERT_EQ(im->width, 10);
    for (int y = 0; y < 10; ++y) {
      for (int x = 0; x < 10; ++x) {
        ASSERT_EQ(p.cells.Value(tl.x() - 1 + x, tl.y() - 1 + y), im->buf[y * im->stride + x])
            << "tag " << id << " cell " << x << "," << y;
      }
    }
  }
}

// --- Checkerboard ---

TEST(Pattern, CheckerboardCornersAreExactOnThe49InchFromTwoViewpoints) {
  const Monitor m = Curved49();
  const PatternPlane plane = TangentPlaneAtCentre(m);
  for (const Eigen::Vector3d& viewpoint : {kCentred, kOffAxis}) {
    const Pattern p = BuildPattern(PatternSpec{}, m, viewpoint, plane);
    const double s = p.spec.square_mm;
    ASSERT_GT(s, 10);
    EXPECT_EQ(p.cells.cell_mm, s);
    EXPECT_EQ(p.cells.width, 16);
    EXPECT_EQ(p.cells.height, 5);
    EXPECT_THAT(p.cells.top_left_mm, EigenNear(Eigen::Vector2d(-8 * s, 2.5 * s), 1e-12));
    EXPECT_EQ(p.cells.Value(0, 0), 0);  // top-left square black
    EXPECT_EQ(p.cells.Value(1, 0), 255);
    EXPECT_EQ(p.cells.Value(0, 1), 255);
    EXPECT_EQ(p.cells.Value(15, 4), 255);

    ASSERT_EQ(p.features.size(), 60u);  // 15 x 4 inner corners
    EXPECT_THAT(p.features[0].pattern_mm, EigenNear(Eigen::Vector2d(-7 * s, 1.5 * s), 1e-12));
    for (int k = 0; k < 60; ++k) {
      const Feature& f = p.features[k];
      const int row = k / 15, col = k % 15;
      EXPECT_EQ(f.id, fmt::format("c{}", k));
      EXPECT_EQ(f.kind, "corner");
      EXPECT_THAT(f.pattern_mm, EigenNear(Eigen::Vector2d((col - 7) * s, (1.5 - row) * s), 1e-9));
      EXPECT_THAT(f.point_in_screen,
                  EigenNear(Eigen::Vector3d(f.pattern_mm.x(), f.pattern_mm.y(), -1000), 1e-9));
      ASSERT_TRUE(f.display_px.has_value());
      EXPECT_TRUE(f.visible);
      // The inverse mapping of the geometry core gives the pattern point back.
      const auto back = PatternFromDisplayPx(m, viewpoint, plane, *f.display_px);
      ASSERT_TRUE(back.has_value());
      EXPECT_THAT(*back, EigenNear(f.pattern_mm, 1e-9)) << f.id;
    }
    if (viewpoint == kCentred) {
      // On the axis the picture is mirror-symmetric about the display's centre column and row.
      EXPECT_NEAR(p.features[0].display_px->x() + p.features[14].display_px->x(), 5119, 1e-9);
      EXPECT_NEAR(p.features[0].display_px->y() + p.features[45].display_px->y(), 1439, 1e-9);
      // Corners above the centre are above it on the display too (display y grows downward).
      EXPECT_LT(p.features[0].display_px->y(), 719.5);
    }
  }
}

TEST(Pattern, FittedSizeTouchesTheMarginWithoutCrossingIt) {
  const Monitor m = Curved49();
  const PatternPlane plane = TangentPlaneAtCentre(m);
  for (const Eigen::Vector3d& viewpoint : {kCentred, kOffAxis}) {
    for (PatternKind kind : {PatternKind::kCheckerboard, PatternKind::kAprilTag, PatternKind::kBoth}) {
      for (double margin : {0.0, 0.05, 0.2}) {
        PatternSpec spec;
        spec.kind = kind;
        spec.margin = margin;
        spec.centre_mm = {20, -10};
        const Pattern p = BuildPattern(spec, m, viewpoint, plane);
        // Dense sampling (32768 points per edge) finds the extreme of the outline independently of the fit's
        // own search: the margin is kept to 1e-6 px, with no more than 1e-6 px to spare on the binding side.
        const double slack_px = OutlineSlackPx(p, m, viewpoint, 32768);
        EXPECT_GE(slack_px, -1e-6) << PatternKindName(kind) << " margin " << margin;
        EXPECT_LE(slack_px, 1e-6) << PatternKindName(kind) << " margin " << margin;
      }
    }
  }
}

// On a flat monitor with the tangent plane, pattern mm are display mm: the fit has a closed form.
TEST(Pattern, FitOnAFlatMonitorIsAnalytic) {
  const Monitor m = Flat27();
  const double w = m.width_mm, h = m.height_mm;
  const PatternPlane plane = TangentPlaneAtCentre(m);
  for (const Eigen::Vector3d& viewpoint : {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(-250, 90, 350)}) {
    for (const auto& [cols, rows] : {std::pair{16, 5}, std::pair{7, 9}}) {
      for (double margin : {0.0, 0.05, 0.3}) {
        PatternSpec spec;
        spec.cols = cols;
        spec.rows = rows;
        spec.margin = margin;
        const double expected = std::min((1 - 2 * margin) * w / cols, (1 - 2 * margin) * h / rows);
        EXPECT_NEAR(BuildPattern(spec, m, viewpoint, plane).spec.square_mm, expected, 1e-9 * expected)
            << cols << "x" << rows << " margin " << margin;
      }
    }
    // Off-centre: the nearer side binds. Half-width left: W/2 - margin W - 40.
    PatternSpec spec;
    spec.centre_mm = {40, 0};
    const double expected = 2 * (w / 2 - 0.05 * w - 40) / 16;
    EXPECT_NEAR(BuildPattern(spec, m, viewpoint, plane).spec.square_mm, expected, 1e-9 * expected);
    // AprilTag grid: the whole cell grid (2 white cells around 12x3 tags of 8 cells, 4-cell gaps) fills the
    // width: (4 + 12 * 8 + 11 * 4) cells = 144 cells = 18 tags.
    spec = PatternSpec{};
    spec.kind = PatternKind::kAprilTag;
    const Pattern p = BuildPattern(spec, m, viewpoint, plane);
    EXPECT_EQ(p.cells.width, 144);
    EXPECT_EQ(p.cells.height, 4 + 3 * 8 + 2 * 4);
    EXPECT_NEAR(p.spec.tag_mm, 0.9 * w / 18, 1e-9);
    EXPECT_NEAR(p.cells.cell_mm, p.spec.tag_mm / 8, 1e-15);
  }
}

TEST(Pattern, ExplicitSizeIsKeptAndFeaturesOffTheDisplayAreFlagged) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.square_mm = 100;  // 1.6 m of checkerboard: wider than the 1.19 m display
  const Pattern p = BuildPattern(spec, m, kCentred, TangentPlaneAtCentre(m));
  EXPECT_EQ(p.spec.square_mm, 100);
  EXPECT_EQ(p.cells.cell_mm, 100);
  int visible = 0;
  for (const Feature& f : p.features) {
    ASSERT_TRUE(f.display_px.has_value());
    const Eigen::Vector2d& px = *f.display_px;
    EXPECT_EQ(f.visible, px.x() >= -0.5 && px.x() <= 5119.5 && px.y() >= -0.5 && px.y() <= 1439.5) << f.id;
    visible += f.visible;
  }
  EXPECT_GT(visible, 0);
  EXPECT_LT(visible, 60);
  // c7 (a = 0, b = 150 mm) is on the display; c0 at a = -700 mm is beyond its left edge (~ -630 mm here).
  EXPECT_FALSE(p.features[0].visible);
  EXPECT_TRUE(p.features[7].visible);
}

// --- AprilTag ---

TEST(Pattern, AprilTagCellsDecodeWithTheRightIdsAndCorners) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.kind = PatternKind::kAprilTag;
  spec.tag_cols = 4;
  spec.tag_rows = 2;
  spec.first_tag_id = 17;
  const Pattern p = BuildPattern(spec, m, kOffAxis, TangentPlaneAtCentre(m));
  EXPECT_EQ(p.cells.width, 2 + 4 * 8 + 3 * 4 + 2);
  EXPECT_EQ(p.cells.height, 2 + 2 * 8 + 1 * 4 + 2);
  EXPECT_NEAR(p.cells.cell_mm, p.spec.tag_mm / 8, 1e-15);
  ASSERT_EQ(p.features.size(), 8u * 4);
  EXPECT_EQ(p.features[0].id, "t17.0");
  EXPECT_EQ(p.features[0].kind, "tag_corner");
  EXPECT_EQ(p.features[31].id, "t24.3");
  // Tag 17 is the top-left one: its black border starts 2 cells in; corner 3 is its top-left corner.
  EXPECT_THAT(p.features[3].pattern_mm, EigenNear(p.cells.CornerMm(2, 2), 1e-12));
  EXPECT_THAT(p.features[0].pattern_mm, EigenNear(p.cells.CornerMm(2, 10), 1e-12));
  EXPECT_THAT(p.features[1].pattern_mm, EigenNear(p.cells.CornerMm(10, 10), 1e-12));
  EXPECT_THAT(p.features[2].pattern_mm, EigenNear(p.cells.CornerMm(10, 2), 1e-12));
  // Tag 22 is row 1, column 1: cells (2 + 12, 2 + 12).
  EXPECT_THAT(p.features[5 * 4 + 3].pattern_mm, EigenNear(p.cells.CornerMm(14, 14), 1e-12));
  for (const Feature& f : p.features) {
    ASSERT_TRUE(f.display_px.has_value());
    EXPECT_TRUE(f.visible);
    EXPECT_THAT(*PatternFromDisplayPx(m, kOffAxis, p.plane, *f.display_px), EigenNear(f.pattern_mm, 1e-9));
  }
  // White quiet zone around the grid, black border around each tag.
  for (int c = 0; c < p.cells.width; ++c) EXPECT_EQ(p.cells.Value(c, 1), 255);
  for (int c = 2; c < 10; ++c) EXPECT_EQ(p.cells.Value(c, 2), 0);

  std::map<int, Eigen::Vector2i> top_left;
  for (int i = 0; i < 8; ++i) top_left[17 + i] = Eigen::Vector2i(2 + (i % 4) * 12, 2 + (i / 4) * 12);
  ExpectTagsMatchLibapriltag(p, top_left);
  const std::vector<int> ids = {17, 18, 19, 20, 21, 22, 23, 24};
  ExpectTagsDecode(p, ids);
  // The detector's default settings, as the analysis will use them: within its 1/8 px edge-refinement bias.
  const double worst_px = ExpectTagsDecode(p, ids, /*refine_edges=*/true, /*tol_px=*/0.5);
  EXPECT_LT(worst_px, 0.25);
}

TEST(Pattern, LastIdsOfTheFamilyDecode) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.kind = PatternKind::kAprilTag;
  spec.tag_cols = 7;
  spec.tag_rows = 1;
  spec.first_tag_id = 580;
  spec.tag_gap_cells = 2;
  const Pattern p = BuildPattern(spec, m, kCentred, TangentPlaneAtCentre(m));
  ExpectTagsDecode(p, {580, 581, 582, 583, 584, 585, 586});
}

// --- Both ---

TEST(Pattern, BothHasCheckerCornersAndATagInEveryWhiteSquare) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.kind = PatternKind::kBoth;
  spec.cols = 6;
  spec.rows = 4;
  spec.first_tag_id = 3;
  const Pattern p = BuildPattern(spec, m, kOffAxis, TangentPlaneAtCentre(m));
  const double s = p.spec.square_mm;
  EXPECT_NEAR(p.spec.tag_mm, s * 8 / 12, 1e-12);
  EXPECT_NEAR(p.cells.cell_mm, s / 12, 1e-15);
  EXPECT_EQ(p.cells.width, 72);
  EXPECT_EQ(p.cells.height, 48);
  ASSERT_EQ(p.features.size(), 15u + 12u * 4);  // 5 x 3 corners, 12 white squares
  int corners = 0, tag_corners = 0;
  for (const Feature& f : p.features) (f.kind == "corner" ? corners : tag_corners) += 1;
  EXPECT_EQ(corners, 15);
  EXPECT_EQ(tag_corners, 48);
  EXPECT_EQ(p.features[0].id, "c0");
  EXPECT_THAT(p.features[0].pattern_mm, EigenNear(p.cells.CornerMm(12, 12), 1e-12));
  EXPECT_THAT(p.features[0].pattern_mm, EigenNear(Eigen::Vector2d(-2 * s, s), 1e-9));
  EXPECT_EQ(p.features[14].id, "c14");
  EXPECT_EQ(p.features[15].id, "t3.0");
  EXPECT_EQ(p.features.back().id, "t14.3");
  // Square (1, 0) is the first white one: tag 3's top-left corner is 2 cells inside it.
  EXPECT_THAT(p.features[15 + 3].pattern_mm, EigenNear(p.cells.CornerMm(14, 2), 1e-12));
  // Row 1 starts with a white square: tag 6 sits in square (0, 1).
  EXPECT_THAT(p.features[15 + 3 * 4 + 3].pattern_mm, EigenNear(p.cells.CornerMm(2, 14), 1e-12));
  EXPECT_EQ(p.cells.Value(0, 0), 0);
  EXPECT_EQ(p.cells.Value(12, 0), 255);  // white square, quiet zone
  EXPECT_EQ(p.cells.Value(14, 2), 0);    // tag border
  for (const Feature& f : p.features) {
    EXPECT_TRUE(f.visible) << f.id;
    EXPECT_THAT(*PatternFromDisplayPx(m, kOffAxis, p.plane, *f.display_px), EigenNear(f.pattern_mm, 1e-9));
  }
  std::map<int, Eigen::Vector2i> top_left;
  int id = 3;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 6; ++c) {
      if ((r + c) % 2 == 1) top_left[id++] = Eigen::Vector2i(12 * c + 2, 12 * r + 2);
    }
  }
  ExpectTagsMatchLibapriltag(p, top_left);
  ExpectTagsDecode(p, {3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14});
}

TEST(Pattern, BothAcceptsATagSizeInsteadOfASquareSize) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.kind = PatternKind::kBoth;
  spec.tag_mm = 40;
  const Pattern p = BuildPattern(spec, m, kCentred, TangentPlaneAtCentre(m));
  EXPECT_NEAR(p.spec.square_mm, 60, 1e-12);
  EXPECT_NEAR(p.cells.cell_mm, 5, 1e-12);
}

// --- Errors ---

TEST(Pattern, KindNames) {
  for (PatternKind k : {PatternKind::kCheckerboard, PatternKind::kAprilTag, PatternKind::kBoth}) {
    EXPECT_EQ(ParsePatternKind(PatternKindName(k), "x"), k);
  }
  EXPECT_THAT(
      MessageOf([] { ParsePatternKind("charuco", "--pattern"); }),
      HasSubstr("--pattern: pattern kind 'charuco' is not known; use checkerboard, apriltag or both"));
}

TEST(Pattern, BadSpecsAreClearErrors) {
  const auto check = [](const std::function<void(PatternSpec&)>& edit) {
    PatternSpec s;
    edit(s);
    return MessageOf([&] { s.Check("spec.yaml"); });
  };
  EXPECT_EQ(check([](PatternSpec&) {}), "(no error)");
  EXPECT_THAT(check([](PatternSpec& s) { s.cols = 0; }), HasSubstr("spec.yaml: pattern has 0x5 squares"));
  EXPECT_THAT(check([](PatternSpec& s) { s.rows = -3; }), HasSubstr("at least 2x2"));
  EXPECT_THAT(check([](PatternSpec& s) { s.cols = 1; }), HasSubstr("at least 2x2"));
  EXPECT_THAT(check([](PatternSpec& s) { s.square_mm = std::nan(""); }), HasSubstr("non-finite"));
  EXPECT_THAT(check([](PatternSpec& s) { s.centre_mm.y() = INFINITY; }), HasSubstr("non-finite"));
  EXPECT_THAT(check([](PatternSpec& s) { s.tag_mm = -1; }), HasSubstr("is negative"));
  EXPECT_THAT(check([](PatternSpec& s) { s.margin = 0.95; }),
              HasSubstr("margin is 0.95; it must be in [0, 0.45)"));
  EXPECT_THAT(check([](PatternSpec& s) { s.margin = -0.1; }), HasSubstr("margin is -0.1"));
  EXPECT_THAT(check([](PatternSpec& s) { s.margin = std::nan(""); }), HasSubstr("non-finite"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kAprilTag;
                s.tag_rows = 0;
              }),
              HasSubstr("pattern has 12x0 tags"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kAprilTag;
                s.first_tag_id = 580;  // 36 tags: 580..615
              }),
              HasSubstr("tag ids run from 580 to 615, but tag36h11 has ids 0 to 586"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kAprilTag;
                s.first_tag_id = -1;
              }),
              HasSubstr("tag ids run from -1"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kBoth;
                s.cols = 30;
                s.rows = 40;  // 600 white squares
              }),
              HasSubstr("tag ids run from 0 to 599"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kAprilTag;
                s.tag_gap_cells = 1;
              }),
              HasSubstr("tag_gap_cells is 1"));
  EXPECT_THAT(check([](PatternSpec& s) {
                s.kind = PatternKind::kBoth;
                s.square_mm = 60;
                s.tag_mm = 30;
              }),
              HasSubstr("tags are 8/12 of a square"));
  EXPECT_THAT(check([](PatternSpec& s) { s.cols = s.rows = 100000; }), HasSubstr("more than the limit"));
  // The checkerboard does not look at the tag fields, nor the tag grid at the board's.
  EXPECT_EQ(check([](PatternSpec& s) { s.tag_cols = 0; }), "(no error)");
  EXPECT_EQ(check([](PatternSpec& s) {
              s.kind = PatternKind::kAprilTag;
              s.cols = 0;
            }),
            "(no error)");

  // BuildPattern checks the spec, the viewpoint and the plane first.
  const Monitor m = Curved49();
  PatternSpec bad;
  bad.margin = 0.95;
  EXPECT_THAT(MessageOf([&] { BuildPattern(bad, m, kCentred, TangentPlaneAtCentre(m)); }),
              HasSubstr("margin"));
  EXPECT_THROW(BuildPattern(PatternSpec{}, m, {0, 0, -1200}, TangentPlaneAtCentre(m)),
               Error);  // behind the screen
  PatternPlane skew = TangentPlaneAtCentre(m);
  skew.y_axis_in_screen = Eigen::Vector3d(0.5, 1, 0).normalized();
  EXPECT_THROW(BuildPattern(PatternSpec{}, m, kCentred, skew), Error);
}

TEST(Pattern, NothingFitsIsAnError) {
  const Monitor m = Curved49();
  PatternSpec spec;
  spec.centre_mm = {5000, 0};  // far beyond the right edge
  EXPECT_THAT(MessageOf([&] { BuildPattern(spec, m, kCentred, TangentPlaneAtCentre(m)); }),
              HasSubstr("no checkerboard of 16x5 squares centred at (5000, 0) mm fits"));
}

TEST(PatternSpecFromConfig, ReadsEveryKey) {
  const PatternSpec s =
      PatternSpecFromConfig(ConfigMap::Parse("kind: apriltag\ncols: 8\nrows: 6\nsquare_mm: 25\ntag_cols: "
                                             "6\ntag_rows: 2\nfirst_tag_id: 10\ntag_mm: 30\n"
                                             "tag_gap_cells: 3\nmargin: 0.1\ncentre_mm: [5, -2.5]\n",
                                             "p.yaml"));
  EXPECT_EQ(s.kind, PatternKind::kAprilTag);
  EXPECT_EQ(s.cols, 8);
  EXPECT_EQ(s.rows, 6);
  EXPECT_EQ(s.square_mm, 25);
  EXPECT_EQ(s.tag_cols, 6);
  EXPECT_EQ(s.tag_rows, 2);
  EXPECT_EQ(s.first_tag_id, 10);
  EXPECT_EQ(s.tag_mm, 30);
  EXPECT_EQ(s.tag_gap_cells, 3);
  EXPECT_EQ(s.margin, 0.1);
  EXPECT_THAT(s.centre_mm, EigenNear(Eigen::Vector2d(5, -2.5), 0));
  // JSON is YAML; missing keys keep the defaults.
  const PatternSpec j = PatternSpecFromConfig(ConfigMap::Parse(R"({"kind": "both", "cols": 7})", "p.json"));
  EXPECT_EQ(j.kind, PatternKind::kBoth);
  EXPECT_EQ(j.cols, 7);
  EXPECT_EQ(j.rows, 5);
  EXPECT_EQ(j.square_mm, 0);
  EXPECT_EQ(j.margin, 0.05);
}

TEST(PatternSpecFromConfig, RejectsBadValuesNamingFileAndKey) {
  const auto read = [](const std::string& yaml) {
    return MessageOf([&] { PatternSpecFromConfig(ConfigMap::Parse(yaml, "p.yaml")); });
  };
  EXPECT_THAT(read("colz: 3\n"),
              HasSubstr("p.yaml: key 'colz' is not a known key; expected one of: kind, cols"));
  EXPECT_THAT(read("kind: chess\n"), HasSubstr("p.yaml: key 'kind' is 'chess', not a pattern kind"));
  EXPECT_THAT(read("cols: 0\n"),
              HasSubstr("p.yaml: key 'cols' is 0, but must be a whole number of at least 1"));
  EXPECT_THAT(read("rows: -2\n"), HasSubstr("key 'rows' is -2"));
  EXPECT_THAT(read("square_mm: -2\n"), HasSubstr("key 'square_mm' is -2, but must not be negative"));
  EXPECT_THAT(read("tag_mm: .nan\n"), HasSubstr("key 'tag_mm' is '.nan', not a finite number"));
  EXPECT_THAT(read("first_tag_id: 1.5\n"), HasSubstr("key 'first_tag_id' is 1.5"));
  EXPECT_THAT(read("kind: apriltag\nfirst_tag_id: 587\n"), HasSubstr("p.yaml: pattern tag ids run from 587"));
  EXPECT_THAT(read("margin: 0.95\n"), HasSubstr("p.yaml: pattern margin is 0.95"));
  EXPECT_THAT(read("centre_mm: [1]\n"), HasSubstr("key 'centre_mm' must be a list of 2 numbers"));
  // Nested under a key of a larger file: the key path is named.
  const ConfigMap outer = ConfigMap::Parse("pattern:\n  margin: 2\n", "scene.yaml");
  EXPECT_THAT(MessageOf([&] { PatternSpecFromConfig(outer.Map("pattern")); }),
              HasSubstr("scene.yaml: key 'pattern': pattern margin is 2"));
}

}  // namespace
}  // namespace curvecheck
