// What feature detection needs from pattern.json, and the plane-to-image homography its screening and the tag
// path's board-corner prediction fit (internal to detect/; detect.h states the rules).
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "pattern/pattern_json.h"

namespace curvecheck::detect_internal {

// What detection needs from pattern.json.
struct PatternInfo {
  std::string kind;        // checkerboard | apriltag | both
  int cols = 0, rows = 0;  // squares (board kinds)
  double square_mm = 0;    // board kinds
  std::map<std::string, Eigen::Vector2d> pattern_mm;  // every feature id -> plane coordinates
  std::set<int> tag_ids;                              // tags of the pattern (from the feature ids)
  int board_corners = 0, tag_corners = 0;
};

// pattern.json's kind, board size and feature coordinates; throws Error (pattern.json, the problem, write it again
// with curvecheck render) where they are missing or inconsistent.
PatternInfo ReadPatternInfo(const PatternFile& pattern);

// Tag ids as ranges, "0..5, 9".
std::string TagIdRanges(const std::set<int>& ids);

// Homography from the pattern plane (mm) to the image (px) by least squares with h33 = 1 on normalized
// coordinates; nullopt if the points are fewer than 4 or degenerate.
std::optional<Eigen::Matrix3d> FitHomography(const std::vector<Eigen::Vector2d>& from,
                                             const std::vector<Eigen::Vector2d>& to);
Eigen::Vector2d ApplyHomography(const Eigen::Matrix3d& h, const Eigen::Vector2d& p);

}  // namespace curvecheck::detect_internal
