#include "pattern/board.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "core/correction.h"
#include "core/file_io.h"
#include "core/monitor.h"
#include "core/screen_geometry.h"
#include "core/test_util.h"
#include "pattern/pattern.h"
#include "pattern/pattern_json.h"

namespace curvecheck {
namespace {
using ::testing::HasSubstr;
using testing::EigenNear;
using testing::MessageOf;

TEST(Board, ParsesSizeAndLaysOutCornersRowMajor) {
  const BoardSpec b = BoardFromText("9x6", 25);
  EXPECT_EQ(b.corners_x, 9);
  EXPECT_EQ(b.corners_y, 6);
  const auto c = b.CornersInBoard();
  ASSERT_EQ(c.size(), 54u);
  EXPECT_THAT(c[1], EigenNear(Eigen::Vector3d(25, 0, 0), 1e-12));
  EXPECT_THAT(c[9], EigenNear(Eigen::Vector3d(0, 25, 0), 1e-12));
}

TEST(Board, RefusesBadSizes) {
  EXPECT_THAT(MessageOf([] { BoardFromText("9by6", 25); }), HasSubstr("not of the form NxM"));
  EXPECT_THAT(MessageOf([] { BoardFromText("1x6", 25); }), HasSubstr("too few inner corners"));
  EXPECT_THAT(MessageOf([] { BoardFromText("9x6", -1); }), HasSubstr("--square-mm"));
}


// Writes the pattern.json of a checkerboard rendered (geometry only, no GPU needed) for `monitor`.
std::filesystem::path WritePattern(const Monitor& monitor, PatternKind kind, const std::string& name) {
  PatternSpec spec;
  spec.kind = kind;
  spec.cols = 10;
  spec.rows = 7;
  const Eigen::Vector3d viewpoint = ScreenCentreInScreen(monitor) + Eigen::Vector3d(30, -20, 700);
  const Pattern p = BuildPattern(spec, monitor, viewpoint, TangentPlaneAtCentre(monitor));
  const auto path = std::filesystem::temp_directory_path() / name;
  WriteFileAtomic(path, PatternToJson(p, monitor, viewpoint, {{"name", "exact"}}).dump());
  return path;
}

// The monitor as the target: on a flat monitor the rendered checkerboard's squares are square_mm on the screen;
// the board is 9x6 inner corners for 10x7 squares.
TEST(Board, FromPatternJsonOfAFlatMonitor) {
  const Monitor flat = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  const auto path = WritePattern(flat, PatternKind::kCheckerboard, "calibrate_board_flat.json");
  const BoardSpec b = BoardFromPatternJson(path);
  EXPECT_EQ(b.corners_x, 9);
  EXPECT_EQ(b.corners_y, 6);
  // The fitted square: min((1 - 2 margin) W / cols, (1 - 2 margin) H / rows) (pattern/pattern.h).
  EXPECT_NEAR(b.square_mm, std::min(0.9 * flat.width_mm / 10, 0.9 * flat.height_mm / 7), 1e-9);
  EXPECT_EQ(b.source, path.string());
}

TEST(Board, FromPatternJsonRefusesCurvedMonitorsAndTags) {
  const Monitor curved = MonitorFromDiagonal("34 1900R", 3440, 1440, 34, 1900);
  EXPECT_THAT(MessageOf([&] { BoardFromPatternJson(WritePattern(curved, PatternKind::kCheckerboard, "calibrate_board_curved.json")); }),
              HasSubstr("curved monitor"));
  const Monitor flat = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  EXPECT_THAT(MessageOf([&] { BoardFromPatternJson(WritePattern(flat, PatternKind::kAprilTag, "calibrate_board_tags.json")); }),
              HasSubstr("not a plain checkerboard"));
}

}  // namespace
}  // namespace curvecheck
