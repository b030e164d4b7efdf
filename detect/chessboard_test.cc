#include "detect/chessboard.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>

#include "synth/synthetic_board.h"
#include "core/stopwatch.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {
using ::testing::HasSubstr;
using testing::MessageOf;

TEST(Detect, MrgingghamRefusesNonSquareBoards) {
  ChessboardOptions o;
  o.detector = ChessboardDetector::kMrgingham;
  EXPECT_THAT(MessageOf([&] { DetectChessboards({}, BoardFromText("9x6", 25), o); }), HasSubstr("square NxN"));
  EXPECT_THAT(MessageOf([&] { ParseChessboardDetector("sift"); }), HasSubstr("not a detector"));
}

// Corner accuracy against the synthetic truth, both detectors on the same photos (an 8x8 board so that mrgingham
// can take it; 1280x960, blur 0.8 px, noise). This is the measurement behind "auto = opencv" (detect.h); the
// assertion holds the chosen detector to the 0.1 px that calibration needs.
TEST(Detect, CornersMatchTheTruthAndAutoIsTheMoreAccurate) {
  SyntheticBoardOptions o;
  o.camera = PinholeModel(1280, 960, 1100);
  o.views = 6;
  o.corners_x = 8;
  o.corners_y = 8;
  o.square_display_px = 40;
  o.seed = 3;
  const SyntheticBoardSet set = MakeSyntheticBoardSet(o);
  double rms[2] = {0, 0}, ms[2] = {0, 0};
  int found[2] = {0, 0}, n[2] = {0, 0};
  for (int det = 0; det < 2; ++det) {
    ChessboardOptions d;
    d.detector = det == 0 ? ChessboardDetector::kAuto : ChessboardDetector::kMrgingham;
    for (const SyntheticBoardView& v : set.views) {
      const Stopwatch watch;
      const ChessboardDetection r = DetectChessboard(v.photo, set.board, d);
      ms[det] += watch.Ms();
      if (!r.found) continue;
      ++found[det];
      for (const Eigen::Vector2d& q : r.corners_px) {
        double best = 1e30;
        for (const Eigen::Vector2d& t : v.corners_px) best = std::min(best, (q - t).squaredNorm());
        rms[det] += best;
        ++n[det];
      }
    }
    rms[det] = std::sqrt(rms[det] / std::max(1, n[det]));
    std::cout << ChessboardDetectorName(d.detector) << ": " << found[det] << "/" << set.views.size() << " found, corner RMS " << rms[det]
              << " px against truth, " << ms[det] / set.views.size() << " ms per photo\n";
  }
  EXPECT_EQ(found[0], 6);
  EXPECT_LT(rms[0], 0.1);
  if (found[1] > 0) {
    EXPECT_LT(rms[0], rms[1]);
  }
}

}  // namespace
}  // namespace curvecheck
