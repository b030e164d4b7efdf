#include "detect/chessboard.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <opencv2/core.hpp>

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

// Mirrored calibration photos (chessboard.h): a 9x7 board (10 x 8 squares, even x even) flipped either way is
// refused on its colours alone; the photos as taken are not. A 10x7 board (11 x 8 squares) is its own mirror
// image left to right, and flipped top to bottom has the colours of the board turned by 180 deg: calibration
// photos may show the board at any roll, so neither flip can be refused (asserted, so that a change is seen).
TEST(Chessboard, MirroredBoardPhotosAreRefused) {
  for (int corners_x : {9, 10}) {
    SyntheticBoardOptions o;
    o.camera = PinholeModel(960, 720, 820);
    o.views = 3;
    o.corners_x = corners_x;
    o.corners_y = 7;
    o.square_display_px = 40;
    o.seed = 5;
    const SyntheticBoardSet set = MakeSyntheticBoardSet(o);
    for (size_t k = 0; k < set.views.size(); ++k) {
      const cv::Mat& photo = set.views[k].photo;
      const ChessboardDetection d = DetectChessboard(photo, set.board, ChessboardOptions());
      EXPECT_TRUE(d.found) << corners_x << " view " << k << ": " << d.problem;
      EXPECT_EQ(d.problem, "");
      for (int flip : {1, 0}) {
        cv::Mat mirrored;
        cv::flip(photo, mirrored, flip);
        const ChessboardDetection m = DetectChessboard(mirrored, set.board, ChessboardOptions());
        if (corners_x == 10) {
          EXPECT_TRUE(m.found) << "view " << k << " flip " << flip << ": " << m.problem;
          continue;
        }
        std::cout << "9x7 view " << k << " flipped (" << flip << "): " << m.problem << "\n";
        EXPECT_FALSE(m.found) << "view " << k << " flip " << flip;
        EXPECT_TRUE(m.corners_px.empty());
        EXPECT_THAT(m.problem, ::testing::StartsWith("mirrored: the board's square colours fit only a mirrored view "
                                                     "of it (handedness +"));
        EXPECT_THAT(m.problem, HasSubstr("turn mirroring off or flip the photo back"));
        // The check can be turned off (a board whose top-left square is white).
        ChessboardOptions off;
        off.refuse_mirrored = false;
        EXPECT_TRUE(DetectChessboard(mirrored, set.board, off).found) << "view " << k << " flip " << flip;
      }
    }
  }
}

}  // namespace
}  // namespace curvecheck
