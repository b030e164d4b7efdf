// Patterns on the virtual plane (architecture.md, "Virtual pattern"): a checkerboard, an AprilTag grid
// (tag36h11) or both (a ChArUco-style board: tags inside the white squares), with the exact ground truth of
// every feature.
//
// Every pattern is represented as a binary grid of square cells on the plane (PatternCells). Every edge of
// every pattern is a cell edge, so a renderer that samples the cells exactly draws every edge exactly where
// the features say, at any resolution; outside the cells the renderer draws a grey surround.
//
// Pattern plane coordinates (a, b) are in mm with a to the right and b up (PatternPlane in core/correction.h).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/correction.h"
#include "core/monitor.h"

namespace curvecheck {

class ConfigMap;

enum class PatternKind {
  kCheckerboard,  // "checkerboard"
  kAprilTag,      // "apriltag": a grid of tag36h11 tags
  kBoth,          // "both": checkerboard with a tag36h11 tag centred in every white square
};
const char* PatternKindName(PatternKind kind);
// Parses "checkerboard" | "apriltag" | "both"; throws Error naming `where` otherwise.
PatternKind ParsePatternKind(const std::string& text, const std::string& where);

struct PatternSpec {
  PatternKind kind = PatternKind::kCheckerboard;
  // Checkerboard (also the board of kBoth): squares across and down. Inner corners: (cols-1) x (rows-1).
  int cols = 16;
  int rows = 5;
  // Square edge in mm on the plane. 0 = fit: the largest square (tag, for kAprilTag) for which the whole
  // pattern lies inside the part of the plane visible through the display from the viewpoint, with `margin`
  // left free. kBoth: a square is 12 cells and its tag 8 of them, so tag_mm = square_mm * 8/12; give either
  // (both only if they agree).
  double square_mm = 0;
  // AprilTag grid (kAprilTag): tags across and down, ids first_tag_id, first_tag_id + 1, ... row-major from
  // the top left. tag_mm is the outer edge of the black border (8 cells of tag36h11); 0 = fit.
  int tag_cols = 12;
  int tag_rows = 3;
  int first_tag_id = 0;
  double tag_mm = 0;
  // Gap between neighbouring tags' black borders, in cells of tag_mm/8; at least 2, so that every tag keeps
  // its own 1-cell white border. The grid also has 2 white cells around it.
  int tag_gap_cells = 4;
  // Fraction of the display left free around a fitted pattern on each side, in display pixels: the outline
  // of the whole cell grid must map into [-0.5 + margin Nx, Nx - 0.5 - margin Nx] x [-0.5 + margin Ny,
  // Ny - 0.5 - margin Ny]. On a flat monitor with the tangent plane the fitted square is therefore
  // min((1 - 2 margin) W / cols, (1 - 2 margin) H / rows). In [0, 0.45).
  double margin = 0.05;
  // Pattern centre in plane coordinates (mm).
  Eigen::Vector2d centre_mm = Eigen::Vector2d::Zero();

  // Throws Error naming `where` unless sizes are positive (or 0 = fit), counts >= 2 (checkerboard) or >= 1
  // (tags), ids within tag36h11's 587 codes, margin in [0, 0.9), all finite.
  void Check(const std::string& where) const;
};

// Reads a pattern spec from YAML (keys as the struct fields, kind as text; all optional with the defaults
// above; unknown keys are errors).
PatternSpec PatternSpecFromConfig(const ConfigMap& config);

// The pattern as a binary grid of square cells. Row 0 is the top row (largest b).
struct PatternCells {
  double cell_mm = 0;                                    // edge length of one cell
  Eigen::Vector2d top_left_mm = Eigen::Vector2d::Zero();  // plane coordinates of the top-left corner of cell (0, 0)
  int width = 0;                                         // cells across
  int height = 0;                                        // cells down
  std::vector<uint8_t> values;                           // row-major, 0 = black, 255 = white

  uint8_t Value(int col, int row) const { return values[static_cast<size_t>(row) * width + col]; }
  // Plane coordinates of the corner shared by cells (col-1, row-1) .. (col, row): col in 0..width, row in 0..height.
  Eigen::Vector2d CornerMm(int col, int row) const {
    return {top_left_mm.x() + col * cell_mm, top_left_mm.y() - row * cell_mm};
  }
};

struct Feature {
  // "c<k>": checkerboard inner corner k, row-major from the top left, k = row * (cols - 1) + col.
  // "t<id>.<k>": outer corner k of tag <id>'s black border: 0 bottom-left, 1 bottom-right, 2 top-right,
  // 3 top-left as seen on the pattern (AprilTag's own order, counter-clockwise, for an upright tag).
  std::string id;
  std::string kind;                                   // "corner" | "tag_corner"
  Eigen::Vector2d pattern_mm = Eigen::Vector2d::Zero();  // on the plane
  Eigen::Vector3d point_in_screen = Eigen::Vector3d::Zero();
  // Exact display position from the geometry core (DisplayPxFromPattern); nullopt if the ray misses the surface.
  std::optional<Eigen::Vector2d> display_px;
  bool visible = false;  // display_px lies on the display, [-0.5, N - 0.5] in both axes
};

struct Pattern {
  PatternSpec spec;    // as resolved: fitted sizes filled in
  PatternPlane plane;
  PatternCells cells;
  std::vector<Feature> features;
};

// The smallest elements a display can draw, in display px across (measured at the pattern's centre): a
// checkerboard square below 4 px is a blur of anti-aliasing whose corners no detector finds; a tag's bit cell
// (1/8 of the tag's black border) below 2 px makes the code unreadable.
constexpr double kMinSquareDisplayPx = 4;
constexpr double kMinTagCellDisplayPx = 2;

// Builds the pattern for a monitor, viewpoint and plane: resolves fitted sizes, lays out the cells, and
// projects every feature to the display with the geometry core. Throws Error if the spec is invalid, if the
// viewpoint is invalid, if no pattern of the requested layout fits in the visible part of the plane, or if its
// squares or tag cells would be smaller on the display than kMinSquareDisplayPx / kMinTagCellDisplayPx (the
// error names the monitor).
Pattern BuildPattern(const PatternSpec& spec, const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                     const PatternPlane& plane);

}  // namespace curvecheck
