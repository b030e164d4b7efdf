// The calibration target: a chessboard's inner-corner grid and square size, given on the command line or read
// from a pattern.json that the rig rendered for a flat monitor (the monitor itself as the target).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace curvecheck {

struct BoardSpec {
  int corners_x = 0;      // inner corners per row (OpenCV's pattern width, mrcal's object_width_n)
  int corners_y = 0;      // rows of inner corners
  double square_mm = 0;   // corner spacing, mm
  std::string source;     // "--board" or the pattern.json path (provenance)

  int corner_count() const { return corners_x * corners_y; }
  // Corner k = row * corners_x + col at (col, row) * square_mm in the board plane (z = 0), mm.
  std::vector<Eigen::Vector3d> CornersInBoard() const;
  // Throws Error naming `where` unless both counts are >= 2 and the square size is positive and finite.
  void Check(const std::string& where) const;
};

// "9x6" (inner corners across x down) and a square size in mm. Throws Error naming --board / --square-mm.
BoardSpec BoardFromText(const std::string& size_text, double square_mm);

// The checkerboard of a pattern.json rendered by `curvecheck render` for a FLAT monitor: the pattern plane is the
// screen, so the corners' point_mm are the physical target and the square size follows from the pixel pitch
// (square_mm of the pattern, checked against the corners' spacing). Refuses curved monitors, AprilTag patterns,
// a plane other than the screen and missing corners, with the reason and what to do.
BoardSpec BoardFromPatternJson(const std::filesystem::path& path);

}  // namespace curvecheck
