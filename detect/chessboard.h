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
// named in mirrored order): for a planar grid of equal spacing each of these is a proper pose of the same board,
// so mrcal needs no canonical order.
//
// Mirrored photos (issue 15; detect.h, "Handedness"). A mirrored photo (a webcam or phone "mirror" setting) is a
// photo of a camera whose principal point and distortion are mirrored too: it would bias the calibration, and a
// model calibrated from mirrored photos fits no unmirrored photo. A photo is refused ("mirrored: ...") when the
// board's square colours fit only mirrored views of it: the board is named by its colours
// (ResolveBoardOrientation, top-left square black, as `curvecheck render` and OpenCV's pattern generator draw
// it) and the affine map from the board (column right, row up) to the image has a positive determinant. That is
// decisive for boards of an even number of squares both ways (odd x odd inner corners, e.g. 9x7): in either
// mirror their colours match no turn of the board. Calibration photos may show the board at any roll (a printed
// board is held either way up), so the upright rule of detect.h is not used here: for other boards (e.g. 9x6
// inner corners = 10 x 7 squares, whose mirror image has the colours of the board turned by 180 deg) a mirrored
// photo cannot be told from a turned one and is not refused. A board whose top-left square is white is the mirror
// image of one whose top-left is black (even x even squares): set refuse_mirrored = false for it.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
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
  // Refuse photos whose board colours fit only a mirrored view (above). Assumes the top-left square is black.
  bool refuse_mirrored = true;
  void Check() const;
};

struct ChessboardDetection {
  std::filesystem::path photo;
  int width = 0, height = 0;  // px
  bool found = false;
  std::vector<Eigen::Vector2d> corners_px;  // row-major, BoardSpec::corner_count() of them when found
  std::string detector;                     // which detector found it ("opencv-classic", "opencv-sb", "mrgingham")
  std::string problem;                      // why not found (unreadable photo, no board, "mirrored: ...")
  double ms = 0;                            // wall time for this photo, including decoding
};

// Detects the board in one 8-bit gray image.
ChessboardDetection DetectChessboard(const cv::Mat& gray8, const BoardSpec& board, const ChessboardOptions& options);

// Reads and detects every photo, options.threads at a time. Photos that cannot be read or hold no complete
// board come back with found = false and the reason; only an unreadable photo list throws. on_decoded (optional)
// is called with each readable photo's index and its image as decoded (gray, 8 or 16 bits) before the detection,
// from the thread that reads it (one call per index: it may write to a slot of its own without a lock).
std::vector<ChessboardDetection> DetectChessboards(
    const std::vector<std::filesystem::path>& photos, const BoardSpec& board, const ChessboardOptions& options,
    const std::function<void(size_t index, const cv::Mat& decoded)>& on_decoded = {});

}  // namespace curvecheck
