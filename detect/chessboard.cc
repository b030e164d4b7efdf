#include "detect/chessboard.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <chrono>
#include <cmath>
#include <mrgingham/mrgingham.hh>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"

namespace curvecheck {
namespace {

double SmallestSpacingPx(const std::vector<cv::Point2f>& c, const BoardSpec& b) {
  double best = 1e30;
  for (int r = 0; r < b.corners_y; ++r) {
    for (int k = 0; k < b.corners_x; ++k) {
      const cv::Point2f p = c[static_cast<size_t>(r * b.corners_x + k)];
      if (k + 1 < b.corners_x) best = std::min(best, cv::norm(c[static_cast<size_t>(r * b.corners_x + k + 1)] - p));
      if (r + 1 < b.corners_y) best = std::min(best, cv::norm(c[static_cast<size_t>((r + 1) * b.corners_x + k)] - p));
    }
  }
  return best;
}

bool DetectOpenCv(const cv::Mat& gray, const BoardSpec& b, const ChessboardOptions& o, ChessboardDetection& d) {
  const int longest = std::max(gray.cols, gray.rows);
  const double scale = (o.search_max_px > 0 && longest > o.search_max_px) ? double(o.search_max_px) / longest : 1.0;
  cv::Mat small = gray;
  if (scale < 1.0) cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
  const cv::Size pattern(b.corners_x, b.corners_y);
  std::vector<cv::Point2f> c;
  d.detector = "opencv-classic";
  bool ok = cv::findChessboardCorners(small, pattern, c, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!ok) {
    d.detector = "opencv-sb";
    ok = cv::findChessboardCornersSB(small, pattern, c, cv::CALIB_CB_EXHAUSTIVE);
  }
  if (!ok || c.size() != static_cast<size_t>(b.corner_count())) return false;
  // To full resolution: pixel centres at integers in both, so q_full = (q_small + 0.5) / scale - 0.5.
  for (cv::Point2f& p : c) p = cv::Point2f(float((p.x + 0.5) / scale - 0.5), float((p.y + 0.5) / scale - 0.5));
  const double spacing = SmallestSpacingPx(c, b);
  const int half = static_cast<int>(std::clamp(o.subpix_window_fraction * spacing, 2.0, 30.0));
  const std::vector<cv::Point2f> before = c;
  cv::cornerSubPix(gray, c, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  for (size_t i = 0; i < c.size(); ++i) {
    // A corner that ran more than its window away was pulled off by something else: not a clean detection.
    if (cv::norm(c[i] - before[i]) > half) return false;
    d.corners_px.emplace_back(c[i].x, c[i].y);
  }
  return true;
}

bool DetectMrgingham(const cv::Mat& gray, const BoardSpec& b, ChessboardDetection& d) {
  d.detector = "mrgingham";
  std::vector<mrgingham::PointDouble> pts;
  // A non-null refinement buffer asks mrgingham to refine every corner (it reallocs it; we free it).
  signed char* levels = nullptr;
  const int found = mrgingham::find_chessboard_from_image_array(pts, &levels, b.corners_x, gray);
  free(levels);
  if (found < 0) return false;
  if (pts.size() != static_cast<size_t>(b.corner_count())) return false;
  for (const auto& p : pts) d.corners_px.emplace_back(p.x, p.y);
  return true;
}

}  // namespace

void ChessboardOptions::Check() const {
  if (detector != "auto" && detector != "opencv" && detector != "mrgingham") {
    throw Error("--detector", fmt::format("'{}' is not a detector", detector), "use auto, opencv or mrgingham");
  }
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
  if (options.detector == "mrgingham") {
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
  }
  return d;
}

std::vector<ChessboardDetection> DetectChessboards(const std::vector<std::filesystem::path>& photos, const BoardSpec& board,
                                         const ChessboardOptions& options) {
  options.Check();
  if (options.detector == "mrgingham" && board.corners_x != board.corners_y) {
    throw Error("--detector", fmt::format("mrgingham finds square NxN boards only, not {}x{}", board.corners_x,
                                          board.corners_y),
                "use --detector opencv (or auto)");
  }
  std::vector<ChessboardDetection> out(photos.size());
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t i = next++; i < photos.size(); i = next++) {
      const auto t0 = std::chrono::steady_clock::now();
      try {
        // Through core's header check (format, size cap, cut-off files, which libpng/libjpeg would decode
        // with a warning on stderr).
        cv::Mat gray;
        std::string bytes;
        try {
          bytes = ReadFileToString(photos[i]);
          CheckImageHeader(bytes, photos[i].string());
          gray = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, bytes.data()), cv::IMREAD_GRAYSCALE);
        } catch (const Error& e) {
          out[i].problem = e.problem();
        }
        if (out[i].problem.empty() && gray.empty()) out[i].problem = "cannot be read as an image";
        if (out[i].problem.empty()) {
          out[i] = DetectChessboard(gray, board, options);
        }
      } catch (const std::exception& e) {  // no exception may leave a worker thread
        out[i] = ChessboardDetection();
        out[i].problem = fmt::format("detection failed: {}", e.what());
      }
      out[i].photo = photos[i];
      out[i].ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
  };
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const size_t n = std::min(photos.size(), static_cast<size_t>(options.threads > 0 ? unsigned(options.threads) : cores));
  std::vector<std::thread> pool;
  for (size_t t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  return out;
}

}  // namespace curvecheck
