// Chessboard corner detection for calibration photos: a plain N x M board (no ids, no pattern.json), on the same
// detectors as the feature detection of detect.h (detect_board.h).
//
// Detectors (ChessboardOptions::detector):
//   opencv     RunOpenCvClassic (findChessboardCorners, global threshold then with histogram equalization) on a
//              copy reduced by an integer factor to at most `search_max_px`, falling back to RunOpenCvSb
//              (findChessboardCornersSB) on that copy; then every corner refined at full resolution (RefineXCorner,
//              cornerSubPix) with one window for the board. Any NxM board. This is "auto": dependencies.md
//              measured the classic detector with full-resolution refinement at 0.038-0.046 px RMS against exact
//              truth where the mrgingham library (no preprocessing) gave 0.055-0.166 px, and 17 ms at 24 MP against
//              725 ms; detect/chessboard_test.cc re-measures both on a synthetic photo.
//   mrgingham  the mrgingham library (square NxN boards only), with its own sub-pixel refinement (RunMrgingham).
// Output corners are row-major (corners_x per row), in mrcal's pixel convention (pixel centres at integers).
// The starting corner may differ between photos (a board rotated by 180 deg, or 90 deg for square boards, or
// seen mirrored): for a planar grid of equal spacing each of these is a proper pose of the same board, so mrcal
// needs no canonical order.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pattern/board.h"

namespace curvecheck {

// The detectors above; names (auto, opencv, mrgingham) are parsed and printed only at the edges.
enum class ChessboardDetector { kAuto, kOpenCv, kMrgingham };  // kAuto = kOpenCv
const char* ChessboardDetectorName(ChessboardDetector detector);
// Throws Error("--detector", "'<name>' is not a detector", the list) for any other name.
ChessboardDetector ParseChessboardDetector(const std::string& name);

struct ChessboardOptions {
  ChessboardDetector detector = ChessboardDetector::kAuto;
  // Longest side (px) of the reduced copy that the OpenCV search runs on; the refinement is at full resolution.
  // Smaller is faster; the board's squares must stay >= ~8 px at that scale. 0 = search at full resolution.
  int search_max_px = 1600;
  // Half-size of the cornerSubPix window as a fraction of the smallest corner spacing seen in the photo
  // (capped to [2, 30] px): large enough to gather edge gradients, small enough to stay inside one square.
  double subpix_window_fraction = 0.35;
  int threads = 0;  // photos in parallel; 0 = all cores
  void Check() const;
};

struct ChessboardDetection {
  std::filesystem::path photo;
  int width = 0, height = 0;  // px
  bool found = false;
  std::vector<Eigen::Vector2d> corners_px;  // row-major, BoardSpec::corner_count() of them when found
  std::string detector;                     // which detector found it ("opencv-classic", "opencv-sb", "mrgingham")
  std::string problem;                      // why not found (unreadable photo, no board)
  double ms = 0;                            // wall time for this photo, including decoding
};

// Detects the board in one 8-bit gray image.
ChessboardDetection DetectChessboard(const cv::Mat& gray8, const BoardSpec& board, const ChessboardOptions& options);

// Reads and detects every photo, options.threads at a time. Photos that cannot be read or hold no complete
// board come back with found = false and the reason; only an unreadable photo list throws.
std::vector<ChessboardDetection> DetectChessboards(const std::vector<std::filesystem::path>& photos, const BoardSpec& board,
                                         const ChessboardOptions& options);

}  // namespace curvecheck
