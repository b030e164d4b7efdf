#include "detect/chessboard.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <optional>

#include "core/error.h"
#include "core/file_io.h"
#include "core/parallel.h"
#include "core/stopwatch.h"
#include "detect/detect.h"
#include "detect/detect_board.h"

namespace curvecheck {
namespace {

using detect_internal::CornerGrid;

double SmallestSpacingPx(const CornerGrid& g) {
  double best = 1e30;
  for (int r = 0; r < g.height; ++r) {
    for (int k = 0; k < g.width; ++k) {
      const cv::Point2d p = g.px[static_cast<size_t>(r * g.width + k)];
      if (k + 1 < g.width) best = std::min(best, cv::norm(g.px[static_cast<size_t>(r * g.width + k + 1)] - p));
      if (r + 1 < g.height) best = std::min(best, cv::norm(g.px[static_cast<size_t>((r + 1) * g.width + k)] - p));
    }
  }
  return best;
}

// The shared board detectors of detect_board.h: classic on the reduced copy, then SB on it, then every corner
// refined at full resolution with one window for the whole board.
bool DetectOpenCv(const cv::Mat& gray, const BoardSpec& b, const ChessboardOptions& o, ChessboardDetection& d) {
  const cv::Size inner(b.corners_x, b.corners_y);
  d.detector = "opencv-classic";
  std::optional<CornerGrid> grid = detect_internal::RunOpenCvClassic(gray, inner, o.search_max_px);
  if (!grid) {
    d.detector = "opencv-sb";
    grid = detect_internal::RunOpenCvSb(gray, inner, /*accuracy=*/false, o.search_max_px);
  }
  if (!grid) return false;
  const int half = static_cast<int>(std::clamp(o.subpix_window_fraction * SmallestSpacingPx(*grid), 2.0, 30.0));
  for (const cv::Point2d& coarse : grid->px) {
    const cv::Point2d fine = detect_internal::RefineXCorner(gray, 0, coarse, half);
    // A corner that ran more than its window away was pulled off by something else: not a clean detection.
    if (cv::norm(fine - coarse) > half) return false;
    d.corners_px.emplace_back(fine.x, fine.y);
  }
  return true;
}

bool DetectMrgingham(const cv::Mat& gray, const BoardSpec& b, ChessboardDetection& d) {
  d.detector = "mrgingham";
  const std::optional<CornerGrid> grid = detect_internal::RunMrgingham(gray, b.corners_x);
  if (!grid || grid->px.size() != static_cast<size_t>(b.corner_count())) return false;
  for (const cv::Point2d& p : grid->px) d.corners_px.emplace_back(p.x, p.y);
  return true;
}

// The handedness test (chessboard.h): "" or the "mirrored: ..." problem of a found board.
std::string MirroredProblem(const cv::Mat& gray, const BoardSpec& b, const std::vector<Eigen::Vector2d>& corners_px) {
  CornerGrid grid;
  grid.width = b.corners_x;
  grid.height = b.corners_y;
  for (const Eigen::Vector2d& p : corners_px) grid.px.emplace_back(p.x(), p.y());
  grid.quality.assign(grid.px.size(), 1.0);
  // The upright limit is moot: only a naming whose handedness the colours decide is used.
  const detect_internal::BoardOrientation o =
      detect_internal::ResolveBoardOrientation(grid, gray, b.corners_x + 1, b.corners_y + 1, 45);
  if (!o.failure.empty() || !o.handedness_from_colours || !o.mirrored) return "";
  // Board plane as the pattern's: column to the right, row up (row 0 at the top).
  std::vector<Eigen::Vector2d> plane;
  for (int k : o.corner_index) plane.emplace_back(k % b.corners_x, -(k / b.corners_x));
  const double handedness = detect_internal::AffineHandedness(plane, corners_px);
  if (!(handedness > kMirroredHandedness)) return "";
  return fmt::format("mirrored: the board's square colours fit only a mirrored view of it (handedness {:+.2f}): the "
                     "photo is mirrored (a webcam or phone mirror setting, or flipped in software); turn mirroring "
                     "off or flip the photo back (this assumes the board's top-left square is black; "
                     "a {}x{} board with a white one is the mirror image of that)",
                     handedness, b.corners_x, b.corners_y);
}

}  // namespace

const char* ChessboardDetectorName(ChessboardDetector detector) {
  switch (detector) {
    case ChessboardDetector::kAuto: return "auto";
    case ChessboardDetector::kOpenCv: return "opencv";
    case ChessboardDetector::kMrgingham: return "mrgingham";
  }
  return "auto";
}

ChessboardDetector ParseChessboardDetector(const std::string& name) {
  for (ChessboardDetector d : {ChessboardDetector::kAuto, ChessboardDetector::kOpenCv, ChessboardDetector::kMrgingham}) {
    if (name == ChessboardDetectorName(d)) return d;
  }
  throw Error("--detector", fmt::format("'{}' is not a detector", name), "use auto, opencv or mrgingham");
}

void ChessboardOptions::Check() const {
  if (search_max_px != 0 && search_max_px < 320) {
    throw Error("--search-max-px", fmt::format("{} px is too small to find a board in", search_max_px),
                "use 0 (full resolution) or at least 320");
  }
  if (!(subpix_window_fraction > 0 && subpix_window_fraction < 0.5)) {
    throw Error("subpix_window_fraction", fmt::format("{} is outside (0, 0.5)", subpix_window_fraction),
                "the window must stay within one square");
  }
  if (threads < 0) throw Error("--threads", fmt::format("{} is negative", threads), "use 0 for all cores");
}

ChessboardDetection DetectChessboard(const cv::Mat& gray8, const BoardSpec& board, const ChessboardOptions& options) {
  options.Check();
  ChessboardDetection d;
  d.width = gray8.cols;
  d.height = gray8.rows;
  if (gray8.type() != CV_8UC1) throw Error("DetectChessboard", "the image is not 8-bit gray", "convert it first");
  if (options.detector == ChessboardDetector::kMrgingham) {
    if (board.corners_x != board.corners_y) {
      throw Error("--detector", fmt::format("mrgingham finds square NxN boards only, not {}x{}", board.corners_x,
                                            board.corners_y),
                  "use --detector opencv (or auto)");
    }
    d.found = DetectMrgingham(gray8, board, d);
  } else {
    d.found = DetectOpenCv(gray8, board, options, d);
  }
  if (!d.found) {
    d.corners_px.clear();
    d.problem = fmt::format("no complete {}x{} board found", board.corners_x, board.corners_y);
  } else if (options.refuse_mirrored) {
    d.problem = MirroredProblem(gray8, board, d.corners_px);
    if (!d.problem.empty()) {
      d.found = false;
      d.corners_px.clear();
    }
  }
  return d;
}

std::vector<ChessboardDetection> DetectChessboards(
    const std::vector<std::filesystem::path>& photos, const BoardSpec& board, const ChessboardOptions& options,
    const std::function<void(size_t index, const cv::Mat& decoded)>& on_decoded) {
  options.Check();
  if (options.detector == ChessboardDetector::kMrgingham && board.corners_x != board.corners_y) {
    throw Error("--detector", fmt::format("mrgingham finds square NxN boards only, not {}x{}", board.corners_x,
                                          board.corners_y),
                "use --detector opencv (or auto)");
  }
  std::vector<ChessboardDetection> out(photos.size());
  // One photo per core (at most options.threads); a photo's failure is kept in its detection.
  ParallelFor(static_cast<int>(photos.size()), [&](int k) {
    const size_t i = static_cast<size_t>(k);
    const Stopwatch watch;
    try {
      // Core's one decoder with its header checks (format, size cap, cut-off files), as gray, in 8 bits.
      cv::Mat gray;
      try {
        gray = DecodePhotoGray(ReadFileToString(photos[i]), photos[i].string());
      } catch (const Error& e) {
        out[i].problem = e.problem();
      }
      if (out[i].problem.empty()) {
        if (on_decoded) on_decoded(i, gray);
        if (gray.depth() == CV_16U) gray.convertTo(gray, CV_8U, 1.0 / 257.0);
        out[i] = DetectChessboard(gray, board, options);
      }
    } catch (const std::exception& e) {  // the failure stays with its photo, the others go on
      out[i] = ChessboardDetection();
      out[i].problem = fmt::format("detection failed: {}", e.what());
    }
    out[i].photo = photos[i];
    out[i].ms = watch.Ms();
  }, 1, options.threads);
  return out;
}

}  // namespace curvecheck
