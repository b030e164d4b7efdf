#include "pattern/pattern.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "core/config.h"
#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

constexpr int kTag36h11Codes = 587;
constexpr int kTagCells = 8;           // edge of a tag36h11 black border, in cells (width_at_border)
constexpr int kTagGridQuietCells = 2;  // white cells around a kAprilTag grid: each tag's quiet zone and more
constexpr int kBothSquareCells =
    12;  // kBoth: a square is 12 cells, its tag 8 cells with 2 white cells each side
constexpr int kBothTagInsetCells = (kBothSquareCells - kTagCells) / 2;
constexpr double kMaxCells = 1 << 26;  // 64 Mi cells: far beyond any display, small enough to allocate

// Fitting: boundary samples per edge of the pattern rectangle, refinement and bisection steps.
constexpr int kFitSamplesPerEdge = 512;
constexpr int kFitBisections = 50;
constexpr int kFitGoldenSteps =
    40;  // refines the worst boundary sample by 0.618^40 ~ 5e-9 of 2 sample spacings
constexpr int kFitBracketSteps = 40;  // doublings or halvings of the first guess before giving up

struct FamilyDeleter {
  void operator()(apriltag_family_t* f) const { tag36h11_destroy(f); }
};
using FamilyPtr = std::unique_ptr<apriltag_family_t, FamilyDeleter>;

// libapriltag's tag36h11, checked against the layout this file relies on.
FamilyPtr Tag36h11() {
  FamilyPtr fam(tag36h11_create());
  bool ok = fam && fam->ncodes == kTag36h11Codes && fam->nbits == 36 && fam->width_at_border == kTagCells &&
            fam->total_width == kTagCells + 2 && !fam->reversed_border;
  for (uint32_t i = 0; ok && i < fam->nbits; ++i) {
    ok = fam->bit_x[i] >= 1 && fam->bit_x[i] < kTagCells - 1 && fam->bit_y[i] >= 1 &&
         fam->bit_y[i] < kTagCells - 1;
  }
  if (!ok) {
    throw Error("libapriltag",
                "its tag36h11 family does not have the expected layout (587 codes of 36 bits, 8-cell border)",
                "install AprilTag 3 (libapriltag-dev)");
  }
  return fam;
}

std::optional<PatternKind> KindFromName(const std::string& text) {
  for (PatternKind k : {PatternKind::kCheckerboard, PatternKind::kAprilTag, PatternKind::kBoth}) {
    if (text == PatternKindName(k)) return k;
  }
  return std::nullopt;
}

bool HasBoard(PatternKind k) { return k != PatternKind::kAprilTag; }
bool HasTags(PatternKind k) { return k != PatternKind::kCheckerboard; }

// Number of tags the spec places (0 for a plain checkerboard). kBoth: one per white square; with the top-left
// square black these are the squares with odd col + row, floor(cols rows / 2) of them.
long TagCount(const PatternSpec& s) {
  switch (s.kind) {
    case PatternKind::kCheckerboard:
      return 0;
    case PatternKind::kAprilTag:
      return static_cast<long>(s.tag_cols) * s.tag_rows;
    case PatternKind::kBoth:
      return static_cast<long>(s.cols) * s.rows / 2;
  }
  return 0;
}

// The cell grid of a spec, independent of its size in mm.
struct TagPlacement {
  int id = 0;
  int col = 0;  // top-left cell of the tag's black border
  int row = 0;
};
struct Layout {
  int width = 0;           // cells across
  int height = 0;          // cells down
  int cells_per_size = 1;  // cells per square_mm (checkerboard, both) or per tag_mm (apriltag)
  int square_cells = 0;    // checkerboard square edge in cells; 0 = no checkerboard
  std::vector<TagPlacement> tags;
};

// Cells across for n items of `item` cells separated by `gap` cells, with `border` cells on both sides;
// in double so that absurd counts are caught by the size check instead of overflowing.
double SpanCells(double n, double item, double gap, double border) {
  return 2 * border + n * item + (n - 1) * gap;
}

Layout LayoutOf(const PatternSpec& s) {
  Layout l;
  switch (s.kind) {
    case PatternKind::kCheckerboard:
      l.width = s.cols;
      l.height = s.rows;
      l.cells_per_size = 1;
      l.square_cells = 1;
      break;
    case PatternKind::kAprilTag: {
      l.width = static_cast<int>(SpanCells(s.tag_cols, kTagCells, s.tag_gap_cells, kTagGridQuietCells));
      l.height = static_cast<int>(SpanCells(s.tag_rows, kTagCells, s.tag_gap_cells, kTagGridQuietCells));
      l.cells_per_size = kTagCells;
      const int pitch = kTagCells + s.tag_gap_cells;
      for (int r = 0; r < s.tag_rows; ++r) {
        for (int c = 0; c < s.tag_cols; ++c) {
          l.tags.push_back({s.first_tag_id + r * s.tag_cols + c, kTagGridQuietCells + c * pitch,
                            kTagGridQuietCells + r * pitch});
        }
      }
      break;
    }
    case PatternKind::kBoth: {
      l.width = s.cols * kBothSquareCells;
      l.height = s.rows * kBothSquareCells;
      l.cells_per_size = kBothSquareCells;
      l.square_cells = kBothSquareCells;
      int id = s.first_tag_id;
      for (int r = 0; r < s.rows; ++r) {
        for (int c = 0; c < s.cols; ++c) {
          if ((r + c) % 2 == 1) {  // white square
            l.tags.push_back(
                {id++, c * kBothSquareCells + kBothTagInsetCells, r * kBothSquareCells + kBothTagInsetCells});
          }
        }
      }
      break;
    }
  }
  return l;
}

// The spec's size in mm that drives the layout: square_mm (checkerboard, both) or tag_mm (apriltag);
// 0 = fit. For kBoth a tag_mm alone sets the square (tag = 8/12 of the square).
double SizeMm(const PatternSpec& s) {
  switch (s.kind) {
    case PatternKind::kCheckerboard:
      return s.square_mm;
    case PatternKind::kAprilTag:
      return s.tag_mm;
    case PatternKind::kBoth:
      return s.square_mm > 0 ? s.square_mm : s.tag_mm * kBothSquareCells / kTagCells;
  }
  return 0;
}

bool InsideRect(const Eigen::Vector2d& p, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  return p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y();
}

// How far a display position lies inside the display shrunk by `margin` of its width (height) on the left
// and right (top and bottom), in display pixels; negative outside, -infinity if there is no position.
double SlackPx(const Monitor& m, double margin, const std::optional<Eigen::Vector2d>& px) {
  if (!px) return -std::numeric_limits<double>::infinity();
  const double mx = margin * m.width_px, my = margin * m.height_px;
  return std::min({px->x() + 0.5 - mx, m.width_px - 0.5 - mx - px->x(), px->y() + 0.5 - my,
                   m.height_px - 0.5 - my - px->y()});
}

// The smallest SlackPx over the boundary of the rectangle centre_mm +- half_extent_mm on the plane. Each
// edge is sampled at kFitSamplesPerEdge points, then the lowest sample is refined by golden-section search
// between its neighbours, so that the fit is tight to far below a pixel rather than to the sample spacing.
double OutlineSlackPx(const Monitor& m, const Eigen::Vector3d& viewpoint, const PatternPlane& plane,
                      const Eigen::Vector2d& centre_mm, const Eigen::Vector2d& half_extent_mm,
                      double margin) {
  const Eigen::Vector2d corners[4] = {
      centre_mm + Eigen::Vector2d(-half_extent_mm.x(), half_extent_mm.y()), centre_mm + half_extent_mm,
      centre_mm + Eigen::Vector2d(half_extent_mm.x(), -half_extent_mm.y()), centre_mm - half_extent_mm};
  double slack_px = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 4; ++e) {
    const Eigen::Vector2d& a = corners[e];
    const Eigen::Vector2d& b = corners[(e + 1) % 4];
    const auto slack_at = [&](double t) {
      return SlackPx(m, margin, DisplayPxFromPattern(m, viewpoint, plane, a + t * (b - a)));
    };
    int worst = 0;
    double worst_slack = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= kFitSamplesPerEdge; ++i) {
      const double g = slack_at(static_cast<double>(i) / kFitSamplesPerEdge);
      if (g < worst_slack) {
        worst_slack = g;
        worst = i;
      }
    }
    if (!std::isfinite(worst_slack)) return worst_slack;  // part of the outline is not on the surface at all
    // Golden-section search for the minimum between the neighbouring samples.
    constexpr double kInvPhi = 0.6180339887498949;
    double lo = static_cast<double>(std::max(worst - 1, 0)) / kFitSamplesPerEdge;
    double hi = static_cast<double>(std::min(worst + 1, kFitSamplesPerEdge)) / kFitSamplesPerEdge;
    double t1 = hi - kInvPhi * (hi - lo), t2 = lo + kInvPhi * (hi - lo);
    double g1 = slack_at(t1), g2 = slack_at(t2);
    for (int i = 0; i < kFitGoldenSteps; ++i) {
      if (g1 < g2) {
        hi = t2;
        t2 = t1;
        g2 = g1;
        t1 = hi - kInvPhi * (hi - lo);
        g1 = slack_at(t1);
      } else {
        lo = t1;
        t1 = t2;
        g1 = g2;
        t2 = lo + kInvPhi * (hi - lo);
        g2 = slack_at(t2);
      }
    }
    slack_px = std::min({slack_px, worst_slack, g1, g2});
  }
  return slack_px;
}

// The largest size (square_mm or tag_mm) for which the outline of the whole cell grid keeps the margin.
// Bisection assumes that the part of the plane that fits is star-shaped about centre_mm (any smaller pattern
// with the same centre fits too), which holds for every viewpoint and plane that see the display as one
// piece.
double FitSizeMm(const PatternSpec& s, const Layout& l, const Monitor& m, const Eigen::Vector3d& viewpoint,
                 const PatternPlane& plane) {
  const Eigen::Vector2d half_extent_per_mm =
      0.5 * Eigen::Vector2d(l.width, l.height) / static_cast<double>(l.cells_per_size);
  const auto fits = [&](double size_mm) {
    return OutlineSlackPx(m, viewpoint, plane, s.centre_mm, size_mm * half_extent_per_mm, s.margin) >= 0;
  };
  const std::string what = HasBoard(s.kind)
                               ? fmt::format("{} of {}x{} squares", PatternKindName(s.kind), s.cols, s.rows)
                               : fmt::format("apriltag grid of {}x{} tags", s.tag_cols, s.tag_rows);
  // First guess: the size that fills the display if the plane were the display itself.
  const double guess =
      std::min(m.width_mm / half_extent_per_mm.x(), m.height_mm / half_extent_per_mm.y()) / 2;
  double lo = 0, hi = 0;
  if (fits(guess)) {
    lo = guess;
    for (int i = 0; i < kFitBracketSteps && hi == 0; ++i) {
      if (fits(2 * lo)) {
        lo *= 2;
      } else {
        hi = 2 * lo;
      }
    }
    if (hi == 0) {
      throw Error(
          "pattern spec",
          fmt::format("the {} still fits at {:.3g} mm: the plane's horizon is inside the display", what, lo),
          "give square_mm or tag_mm explicitly, or use a plane that faces the viewpoint");
    }
  } else {
    hi = guess;
    for (int i = 0; i < kFitBracketSteps && lo == 0; ++i) {
      if (fits(hi / 2)) {
        lo = hi / 2;
      } else {
        hi /= 2;
      }
    }
    if (lo == 0) {
      throw Error(
          "pattern spec",
          fmt::format("no {} centred at ({}, {}) mm fits in the part of the pattern plane seen through the "
                      "display from the viewpoint, with margin {}",
                      what, s.centre_mm.x(), s.centre_mm.y(), s.margin),
          "move centre_mm toward the visible part of the plane or reduce margin");
    }
  }
  for (int i = 0; i < kFitBisections; ++i) {
    const double mid = 0.5 * (lo + hi);
    (fits(mid) ? lo : hi) = mid;
  }
  return lo;
}

// Paints tag `id` with the top-left cell of its black border at (col0, row0). Bit i of the code, counted
// from the most significant of the nbits, is the cell (bit_x[i], bit_y[i]) of the 8 x 8 border square
// (0, 0 = its top-left border cell); 1 = white. This is how libapriltag draws a code (apriltag_to_image);
// the tests check it by decoding rendered tags with the AprilTag detector.
void PaintTag(const apriltag_family_t& fam, int id, int col0, int row0, PatternCells& cells) {
  for (int r = 0; r < kTagCells; ++r) {
    for (int c = 0; c < kTagCells; ++c) {
      cells.values[static_cast<size_t>(row0 + r) * cells.width + (col0 + c)] = 0;
    }
  }
  const uint64_t code = fam.codes[id];
  for (uint32_t i = 0; i < fam.nbits; ++i) {
    if ((code >> (fam.nbits - 1 - i)) & 1) {
      cells.values[static_cast<size_t>(row0 + fam.bit_y[i]) * cells.width + (col0 + fam.bit_x[i])] = 255;
    }
  }
}

Feature MakeFeature(std::string id, const char* kind, const Eigen::Vector2d& pattern_mm, const Monitor& m,
                    const Eigen::Vector3d& viewpoint, const PatternPlane& plane) {
  Feature f;
  f.id = std::move(id);
  f.kind = kind;
  f.pattern_mm = pattern_mm;
  f.point_in_screen = plane.PointInScreen(pattern_mm);
  f.display_px = DisplayPxFromPattern(m, viewpoint, plane, pattern_mm);
  f.visible = f.display_px && InsideRect(*f.display_px, Eigen::Vector2d::Constant(-0.5),
                                         Eigen::Vector2d(m.width_px - 0.5, m.height_px - 0.5));
  return f;
}

}  // namespace

const char* PatternKindName(PatternKind kind) {
  switch (kind) {
    case PatternKind::kCheckerboard:
      return "checkerboard";
    case PatternKind::kAprilTag:
      return "apriltag";
    case PatternKind::kBoth:
      return "both";
  }
  return "?";
}

PatternKind ParsePatternKind(const std::string& text, const std::string& where) {
  const std::optional<PatternKind> k = KindFromName(text);
  if (!k)
    throw Error(where, fmt::format("pattern kind '{}' is not known", text),
                "use checkerboard, apriltag or both");
  return *k;
}

void PatternSpec::Check(const std::string& where) const {
  if (!std::isfinite(square_mm) || !std::isfinite(tag_mm) || !std::isfinite(margin) ||
      !centre_mm.allFinite()) {
    throw Error(
        where,
        fmt::format(
            "pattern spec has a non-finite value (square_mm {}, tag_mm {}, margin {}, centre_mm [{}, {}])",
            square_mm, tag_mm, margin, centre_mm.x(), centre_mm.y()),
        "give finite numbers");
  }
  if (square_mm < 0 || tag_mm < 0) {
    throw Error(where, fmt::format("pattern square_mm {} / tag_mm {} is negative", square_mm, tag_mm),
                "give a size in mm, or 0 to fit the pattern to the display");
  }
  if (!(margin >= 0 && margin < 0.45)) {
    throw Error(where, fmt::format("pattern margin is {}; it must be in [0, 0.45) (a margin of 0.5 per side "
                                   "leaves no display)", margin),
                "give the fraction of the display to leave free on each side, e.g. 0.05");
  }
  if (HasBoard(kind) && (cols < 2 || rows < 2)) {
    throw Error(where,
                fmt::format("pattern has {}x{} squares; a checkerboard needs at least 2x2", cols, rows),
                "set cols and rows to 2 or more");
  }
  if (kind == PatternKind::kAprilTag) {
    if (tag_cols < 1 || tag_rows < 1) {
      throw Error(where, fmt::format("pattern has {}x{} tags", tag_cols, tag_rows),
                  "set tag_cols and tag_rows to 1 or more");
    }
    if (tag_gap_cells < 2) {
      throw Error(
          where,
          fmt::format("pattern tag_gap_cells is {}; neighbouring tags need 2 cells between them for the "
                      "white border of each",
                      tag_gap_cells),
          "set tag_gap_cells to 2 or more");
    }
  }
  if (kind == PatternKind::kBoth && square_mm > 0 && tag_mm > 0 &&
      std::abs(tag_mm * kBothSquareCells / kTagCells - square_mm) > 1e-9 * square_mm) {
    throw Error(
        where,
        fmt::format("pattern of kind both has square_mm {} and tag_mm {}, but its tags are 8/12 of a square",
                    square_mm, tag_mm),
        "give only one of square_mm and tag_mm");
  }
  if (HasTags(kind)) {
    const long last_id = static_cast<long>(first_tag_id) + TagCount(*this) - 1;
    if (first_tag_id < 0 || last_id >= kTag36h11Codes) {
      throw Error(where,
                  fmt::format("pattern tag ids run from {} to {}, but tag36h11 has ids 0 to {}", first_tag_id,
                              last_id, kTag36h11Codes - 1),
                  "lower first_tag_id or use fewer tags");
    }
  }
  double cells = 0;
  switch (kind) {
    case PatternKind::kCheckerboard:
      cells = static_cast<double>(cols) * rows;
      break;
    case PatternKind::kAprilTag:
      cells = SpanCells(tag_cols, kTagCells, tag_gap_cells, kTagGridQuietCells) *
              SpanCells(tag_rows, kTagCells, tag_gap_cells, kTagGridQuietCells);
      break;
    case PatternKind::kBoth:
      cells = static_cast<double>(cols) * rows * kBothSquareCells * kBothSquareCells;
      break;
  }
  // Every feature becomes a pattern.json entry (~300 bytes) and is projected; 2e5 features is ~60 MB of JSON,
  // far beyond what a photo of one display can resolve.
  const double features = (HasBoard(kind) ? static_cast<double>(cols - 1) * (rows - 1) : 0) +
                          (HasTags(kind) ? 4.0 * TagCount(*this) : 0);
  if (features > 2e5) {
    throw Error(where, fmt::format("pattern has {:.3g} features, more than the limit of 200000", features),
                "use fewer squares or tags");
  }
  if (cells > kMaxCells) {
    throw Error(where,
                fmt::format("pattern has {:.3g} cells, more than the limit of {:.3g}", cells, kMaxCells),
                "use fewer squares or tags, or a smaller tag_gap_cells");
  }
}

PatternSpec PatternSpecFromConfig(const ConfigMap& c) {
  c.RejectUnknownKeys({"kind", "cols", "rows", "square_mm", "tag_cols", "tag_rows", "first_tag_id", "tag_mm",
                       "tag_gap_cells", "margin", "centre_mm"});
  const auto size_mm = [&](const char* key) {
    const double v = c.Number(key);
    if (v < 0)
      c.Fail(key, fmt::format("is {}, but must not be negative", v),
             "give a size in mm, or 0 to fit the display");
    return v;
  };
  const auto count = [&](const char* key) {
    const double v = c.Number(key);
    if (v != std::floor(v) || v < 0 || v > 1e9) {
      c.Fail(key, fmt::format("is {}, but must be a whole number of at least 0", v),
             "give a non-negative integer");
    }
    return static_cast<int>(v);
  };
  PatternSpec s;
  if (c.Has("kind")) {
    const std::string text = c.String("kind");
    const std::optional<PatternKind> k = KindFromName(text);
    if (!k) c.Fail("kind", "is '" + text + "', not a pattern kind", "use checkerboard, apriltag or both");
    s.kind = *k;
  }
  if (c.Has("cols")) s.cols = c.PositiveInt("cols");
  if (c.Has("rows")) s.rows = c.PositiveInt("rows");
  if (c.Has("square_mm")) s.square_mm = size_mm("square_mm");
  if (c.Has("tag_cols")) s.tag_cols = c.PositiveInt("tag_cols");
  if (c.Has("tag_rows")) s.tag_rows = c.PositiveInt("tag_rows");
  if (c.Has("first_tag_id")) s.first_tag_id = count("first_tag_id");
  if (c.Has("tag_mm")) s.tag_mm = size_mm("tag_mm");
  if (c.Has("tag_gap_cells")) s.tag_gap_cells = count("tag_gap_cells");
  if (c.Has("margin")) s.margin = c.Number("margin");
  if (c.Has("centre_mm")) {
    const std::vector<double> v = c.Numbers("centre_mm", 2);
    s.centre_mm = {v[0], v[1]};
  }
  s.Check(c.path().empty() ? c.source() : fmt::format("{}: key '{}'", c.source(), c.path()));
  return s;
}

namespace {

// Display px across the smallest element the pattern draws, measured at the pattern's centre: a checkerboard
// square (kinds checkerboard, both) and a tag's bit cell (apriltag, both); nullopt where the centre misses the
// display surface. Throws Error naming the monitor when an element is below its drawable minimum
// (kMinSquareDisplayPx, kMinTagCellDisplayPx in pattern.h): a 1 x 1 px monitor cannot show a 16x5 board.
void CheckDrawable(const Pattern& p, const Monitor& m, const Eigen::Vector3d& viewpoint) {
  const auto span_px = [&](double size_mm) -> std::optional<double> {
    const Eigen::Vector2d c = p.spec.centre_mm, hx(size_mm / 2, 0), hy(0, size_mm / 2);
    const auto a = DisplayPxFromPattern(m, viewpoint, p.plane, c - hx), b = DisplayPxFromPattern(m, viewpoint, p.plane, c + hx);
    const auto d = DisplayPxFromPattern(m, viewpoint, p.plane, c - hy), e = DisplayPxFromPattern(m, viewpoint, p.plane, c + hy);
    if (!a || !b || !d || !e) return std::nullopt;
    return std::min((*b - *a).norm(), (*e - *d).norm());
  };
  const auto check = [&](double size_mm, double min_px, const std::string& what, const std::string& element) {
    const std::optional<double> px = span_px(size_mm);
    if (!px || *px >= min_px) return;
    throw Error(fmt::format("monitor '{}'", m.name),
                fmt::format("{} x {} px cannot show the {}: its {} would be {:.2g} display px across, below the {:g} "
                            "px it needs to be drawn",
                            m.width_px, m.height_px, what, element, *px, min_px),
                "give the monitor's real resolution in its spec, or a pattern of fewer, larger squares or tags "
                "(e.g. --squares 4x3)");
  };
  if (HasBoard(p.spec.kind)) {
    check(p.spec.square_mm, kMinSquareDisplayPx,
          fmt::format("{} of {}x{} squares", PatternKindName(p.spec.kind), p.spec.cols, p.spec.rows), "squares");
  }
  if (p.spec.kind != PatternKind::kCheckerboard) {
    check(p.spec.tag_mm / kTagCells, kMinTagCellDisplayPx,
          p.spec.kind == PatternKind::kAprilTag
              ? fmt::format("apriltag grid of {}x{} tags", p.spec.tag_cols, p.spec.tag_rows)
              : fmt::format("{} of {}x{} squares", PatternKindName(p.spec.kind), p.spec.cols, p.spec.rows),
          "tags' bit cells (1/8 of a tag)");
  }
}

}  // namespace

Pattern BuildPattern(const PatternSpec& spec, const Monitor& monitor,
                     const Eigen::Vector3d& viewpoint_in_screen, const PatternPlane& plane) {
  spec.Check("pattern spec");
  monitor.Check("monitor '" + monitor.name + "'");
  CheckViewpoint(monitor, viewpoint_in_screen, "viewpoint");
  plane.Check("pattern plane");

  const Layout layout = LayoutOf(spec);
  Pattern p;
  p.spec = spec;
  p.plane = plane;
  double size_mm = SizeMm(spec);
  if (size_mm == 0) size_mm = FitSizeMm(spec, layout, monitor, viewpoint_in_screen, plane);
  switch (spec.kind) {
    case PatternKind::kCheckerboard:
      p.spec.square_mm = size_mm;
      break;
    case PatternKind::kAprilTag:
      p.spec.tag_mm = size_mm;
      break;
    case PatternKind::kBoth:
      p.spec.square_mm = size_mm;
      p.spec.tag_mm = size_mm * kTagCells / kBothSquareCells;
      break;
  }

  CheckDrawable(p, monitor, viewpoint_in_screen);

  PatternCells& cells = p.cells;
  cells.cell_mm = size_mm / layout.cells_per_size;
  cells.width = layout.width;
  cells.height = layout.height;
  cells.top_left_mm = spec.centre_mm + 0.5 * cells.cell_mm * Eigen::Vector2d(-layout.width, layout.height);
  cells.values.assign(static_cast<size_t>(cells.width) * cells.height, 255);
  if (layout.square_cells > 0) {  // top-left square black
    for (int r = 0; r < cells.height; ++r) {
      for (int c = 0; c < cells.width; ++c) {
        if ((r / layout.square_cells + c / layout.square_cells) % 2 == 0) {
          cells.values[static_cast<size_t>(r) * cells.width + c] = 0;
        }
      }
    }
  }
  if (!layout.tags.empty()) {
    const FamilyPtr fam = Tag36h11();
    for (const TagPlacement& t : layout.tags) PaintTag(*fam, t.id, t.col, t.row, cells);
  }

  if (HasBoard(spec.kind)) {
    for (int r = 1; r < spec.rows; ++r) {
      for (int c = 1; c < spec.cols; ++c) {
        const int k = (r - 1) * (spec.cols - 1) + (c - 1);
        p.features.push_back(MakeFeature(fmt::format("c{}", k), "corner",
                                         cells.CornerMm(c * layout.square_cells, r * layout.square_cells),
                                         monitor, viewpoint_in_screen, plane));
      }
    }
  }
  for (const TagPlacement& t : layout.tags) {
    // Outer corners of the black border, AprilTag's order: bottom-left, bottom-right, top-right, top-left.
    const Eigen::Vector2d corners_mm[4] = {
        cells.CornerMm(t.col, t.row + kTagCells), cells.CornerMm(t.col + kTagCells, t.row + kTagCells),
        cells.CornerMm(t.col + kTagCells, t.row), cells.CornerMm(t.col, t.row)};
    for (int k = 0; k < 4; ++k) {
      p.features.push_back(MakeFeature(fmt::format("t{}.{}", t.id, k), "tag_corner", corners_mm[k], monitor,
                                       viewpoint_in_screen, plane));
    }
  }
  return p;
}

}  // namespace curvecheck
