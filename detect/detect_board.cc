#include "detect/detect_board.h"

#include <fmt/format.h>
#include <mrgingham/mrgingham.hh>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "core/stats.h"
#include "detect/detect_tags.h"

namespace curvecheck::detect_internal {
namespace {

// Integer factor that brings the longer side to at most max_px (1 = none).
int ScaleFactor(const cv::Mat& image, int max_px) {
  if (max_px <= 0) return 1;
  const int longer = std::max(image.cols, image.rows);
  return std::max(1, (longer + max_px - 1) / max_px);
}

cv::Mat Shrink(const cv::Mat& image, int factor) {
  if (factor == 1) return image;
  cv::Mat small;
  cv::resize(image, small, cv::Size(image.cols / factor, image.rows / factor), 0, 0, cv::INTER_AREA);
  return small;
}

// Pixel i of a copy shrunk by `factor` averages full-resolution pixels factor*i .. factor*i + factor - 1.
cv::Point2d ToFullResolution(const cv::Point2f& p, int factor) {
  return {factor * p.x + 0.5 * (factor - 1), factor * p.y + 0.5 * (factor - 1)};
}

// An OpenCV corner list of the shrunk copy as a grid at full resolution (quality 1: no per-corner measure), or
// nullopt when it is not the whole board.
std::optional<CornerGrid> GridAtFullResolution(const std::vector<cv::Point2f>& corners, cv::Size inner, int factor) {
  if (static_cast<int>(corners.size()) != inner.area()) return std::nullopt;
  CornerGrid g;
  g.width = inner.width;
  g.height = inner.height;
  for (const cv::Point2f& p : corners) g.px.push_back(ToFullResolution(p, factor));
  g.quality.assign(g.px.size(), 1.0);
  return g;
}

constexpr std::pair<int, int> kNeighbours[] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
constexpr std::pair<int, int> kQuadCorners[] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};

struct Candidate {
  std::string name;
  std::vector<int> board_of_detected;  // per detected point: col + row * nc
  double colour = 0;                   // correlation of the observed with the predicted square colours, -1..1
  double up_deg = 0;                   // angle between the board's up and the image's up
  bool mirrored = false;               // the naming needs a reflection (pattern right x down < 0 in the image)
};

// "0, 180": the candidates' angles from upright, rounded, each once.
std::string UpAngles(const std::vector<const Candidate*>& candidates) {
  std::vector<long> deg;
  for (const Candidate* c : candidates) deg.push_back(std::lround(c->up_deg));
  std::sort(deg.begin(), deg.end());
  deg.erase(std::unique(deg.begin(), deg.end()), deg.end());
  std::string out;
  for (long d : deg) out += fmt::format("{}{}", out.empty() ? "" : ", ", d);
  return out;
}

const Candidate* MostUpright(const std::vector<const Candidate*>& candidates) {
  return *std::min_element(candidates.begin(), candidates.end(),
                           [](const Candidate* a, const Candidate* b) { return a->up_deg < b->up_deg; });
}

// One pixel of an 8 or 16 bit one-channel image.
double ValueAt(const cv::Mat& image, int row, int col) {
  return image.depth() == CV_16U ? image.at<uint16_t>(row, col) : image.at<uint8_t>(row, col);
}

}  // namespace

std::optional<CornerGrid> RunMrgingham(const cv::Mat& gray8, int gridn) {
  std::vector<mrgingham::PointDouble> points;
  signed char* levels = nullptr;
  const int found = mrgingham::find_chessboard_from_image_array(points, &levels, gridn, gray8, -1);
  std::optional<CornerGrid> out;
  if (found >= 0 && static_cast<int>(points.size()) == gridn * gridn) {
    out.emplace();
    out->width = out->height = gridn;
    for (size_t i = 0; i < points.size(); ++i) {
      out->px.emplace_back(points[i].x, points[i].y);
      out->quality.push_back(levels ? std::pow(0.5, std::max(0, static_cast<int>(levels[i]))) : 1.0);
    }
  }
  std::free(levels);  // mrgingham realloc()s it; the caller frees (mrgingham.hh)
  return out;
}

std::optional<CornerGrid> RunOpenCvSb(const cv::Mat& gray8, cv::Size inner, bool accuracy, int max_px) {
  const int factor = ScaleFactor(gray8, max_px);
  const cv::Mat small = Shrink(gray8, factor);
  std::vector<cv::Point2f> corners;
  // Without CALIB_CB_NORMALIZE_IMAGE first: the histogram equalization costs accuracy (measured on a 1500 x 1000
  // synthetic photo: 0.31 px RMS from cornerSubPix's corners with it, 0.065 px without).
  const int flags = accuracy ? cv::CALIB_CB_ACCURACY : 0;
  if (!cv::findChessboardCornersSB(small, inner, corners, flags) &&
      !cv::findChessboardCornersSB(small, inner, corners, flags | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return std::nullopt;
  }
  return GridAtFullResolution(corners, inner, factor);
}

std::optional<CornerGrid> RunOpenCvClassic(const cv::Mat& gray8, cv::Size inner, int max_px) {
  const int factor = ScaleFactor(gray8, max_px);
  const cv::Mat small = Shrink(gray8, factor);
  // The global threshold first (milliseconds on a clean photo), then with histogram equalization. Not the
  // adaptive thresholds: they iterate over block sizes and dilations, measured at 50-60 s on a 1500 x 1000
  // photo of a board of another size or of tags (OpenCV 4.6). FAST_CHECK ends both quickly without a board.
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCorners(small, inner, corners, cv::CALIB_CB_FAST_CHECK) &&
      !cv::findChessboardCorners(small, inner, corners, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK)) {
    return std::nullopt;
  }
  return GridAtFullResolution(corners, inner, factor);
}

cv::Point2d RefineXCorner(const cv::Mat& image, double sigma_px, cv::Point2d guess, int half) {
  const int pad = half + 4 + static_cast<int>(std::ceil(3 * sigma_px));
  const cv::Rect roi(static_cast<int>(std::floor(guess.x)) - pad, static_cast<int>(std::floor(guess.y)) - pad,
                     2 * pad + 1, 2 * pad + 1);
  cv::Point origin;
  const cv::Mat patch = SmoothedPatch(image, roi, sigma_px, &origin);
  if (patch.cols <= 2 * half + 3 || patch.rows <= 2 * half + 3) return guess;  // cut by the image edge
  std::vector<cv::Point2f> one{cv::Point2f(static_cast<float>(guess.x - origin.x), static_cast<float>(guess.y - origin.y))};
  cv::cornerSubPix(patch, one, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-3));
  return cv::Point2d(one[0].x + origin.x, one[0].y + origin.y);
}

int RefinementHalfWindowPx(const std::vector<cv::Point2d>& px, int width, int height, int i, int j) {
  const cv::Point2d& p = px[static_cast<size_t>(j * width + i)];
  double nearest = 1e9;
  for (const auto& [di, dj] : kNeighbours) {
    const int ii = i + di, jj = j + dj;
    if (ii < 0 || jj < 0 || ii >= width || jj >= height) continue;
    nearest = std::min(nearest, cv::norm(px[static_cast<size_t>(jj * width + ii)] - p));
  }
  return std::clamp(static_cast<int>(std::lround(0.3 * nearest)), 3, 40);
}

void RefineXCorners(const cv::Mat& image, double sigma_px, CornerGrid& g, double gap_closing_per_spacing) {
  const std::vector<cv::Point2d> coarse = g.px;
  const auto at = [&](int i, int j) {
    return coarse[static_cast<size_t>(std::clamp(j, 0, g.height - 1) * g.width + std::clamp(i, 0, g.width - 1))];
  };
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      const cv::Point2d& p = coarse[static_cast<size_t>(j * g.width + i)];
      const int half = RefinementHalfWindowPx(coarse, g.width, g.height, i, j);
      cv::Point2d& refined = g.px[static_cast<size_t>(j * g.width + i)];
      // The board's edge vectors here, one corner spacing long (from the neighbouring corners), scaled.
      const bool inside_x = i > 0 && i + 1 < g.width, inside_y = j > 0 && j + 1 < g.height;
      const cv::Point2d u = gap_closing_per_spacing * (at(i + 1, j) - at(i - 1, j)) / (inside_x ? 2.0 : 1.0);
      const cv::Point2d v = gap_closing_per_spacing * (at(i, j + 1) - at(i, j - 1)) / (inside_y ? 2.0 : 1.0);
      if (gap_closing_per_spacing <= 0 || g.width < 2 || g.height < 2 || std::max(cv::norm(u), cv::norm(v)) < 2) {
        refined = RefineXCorner(image, sigma_px, p, half);
        continue;
      }
      // The patch RefineXCorner reads, and the kernel's reach around it, closed.
      const int reach =
          static_cast<int>(std::ceil(0.5 * (std::abs(u.x) + std::abs(v.x) + std::abs(u.y) + std::abs(v.y))));
      const int pad = half + 4 + static_cast<int>(std::ceil(3 * sigma_px)) + reach + 1;
      const cv::Rect roi = cv::Rect(static_cast<int>(std::floor(p.x)) - pad, static_cast<int>(std::floor(p.y)) - pad,
                                    2 * pad + 1, 2 * pad + 1) &
                           cv::Rect(0, 0, image.cols, image.rows);
      if (roi.width < 3 || roi.height < 3) {
        refined = RefineXCorner(image, sigma_px, p, half);
        continue;
      }
      const cv::Mat closed = ClosedAlongEdges(image(roi), u, v);
      const cv::Point2d origin(roi.x, roi.y);
      refined = RefineXCorner(closed, sigma_px, p - origin, half) + origin;
    }
  }
}

cv::Mat ClosedAlongEdges(const cv::Mat& patch, cv::Point2d u, cv::Point2d v) {
  // The parallelogram +-u/2 +-v/2 on a kernel of odd size centred on the origin.
  const cv::Point2d corners[] = {0.5 * (u + v), 0.5 * (u - v), -0.5 * (u + v), 0.5 * (v - u)};
  double reach = 0;
  for (const cv::Point2d& c : corners) reach = std::max({reach, std::abs(c.x), std::abs(c.y)});
  const int half = static_cast<int>(std::ceil(reach));
  if (half < 1) return patch.clone();
  cv::Mat kernel = cv::Mat::zeros(2 * half + 1, 2 * half + 1, CV_8U);
  std::vector<cv::Point> polygon;
  for (const cv::Point2d& c : corners) {
    polygon.emplace_back(static_cast<int>(std::lround((c.x + half) * 16)),
                         static_cast<int>(std::lround((c.y + half) * 16)));
  }
  cv::fillConvexPoly(kernel, polygon, cv::Scalar(1), cv::LINE_8, 4);
  // Point-symmetric, as OpenCV's dilation and erosion make a closing only of a symmetric kernel.
  cv::Mat turned;
  cv::flip(kernel, turned, -1);
  kernel = cv::max(kernel, turned);
  cv::Mat closed;
  cv::morphologyEx(patch, closed, cv::MORPH_CLOSE, kernel, cv::Point(half, half), 1, cv::BORDER_REPLICATE);
  return closed;
}

double GridRoughnessPx(const CornerGrid& g) {
  std::vector<double> d;
  const auto at = [&](int i, int j) { return g.px[static_cast<size_t>(j * g.width + i)]; };
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i + 3 < g.width; ++i) {
      const cv::Point2d t = at(i + 3, j) - 3 * at(i + 2, j) + 3 * at(i + 1, j) - at(i, j);
      d.push_back(std::abs(t.x)), d.push_back(std::abs(t.y));
    }
  }
  for (int i = 0; i < g.width; ++i) {
    for (int j = 0; j + 3 < g.height; ++j) {
      const cv::Point2d t = at(i, j + 3) - 3 * at(i, j + 2) + 3 * at(i, j + 1) - at(i, j);
      d.push_back(std::abs(t.x)), d.push_back(std::abs(t.y));
    }
  }
  if (d.empty()) return std::nan("");
  return 1.4826 * Median(std::move(d)) / std::sqrt(20.0);
}

BoardOrientation ResolveBoardOrientation(const CornerGrid& grid, const cv::Mat& image, int cols, int rows,
                                         double upright_max_deg) {
  const int nc = cols - 1, nr = rows - 1;
  const int w = grid.width, h = grid.height;
  BoardOrientation out;
  // Observed colour of every detected quad (i, j)-(i+1, j+1): mean of four samples 15% in from its corners
  // (inside the square; for kind "both" inside the white margin around a tag).
  struct Quad {
    int i, j;
    double value;
  };
  std::vector<Quad> quads;
  double mean = 0;
  for (int j = 0; j + 1 < h; ++j) {
    for (int i = 0; i + 1 < w; ++i) {
      const cv::Point2d& p00 = grid.px[static_cast<size_t>(j * w + i)];
      const cv::Point2d& p10 = grid.px[static_cast<size_t>(j * w + i + 1)];
      const cv::Point2d& p01 = grid.px[static_cast<size_t>((j + 1) * w + i)];
      const cv::Point2d& p11 = grid.px[static_cast<size_t>((j + 1) * w + i + 1)];
      double sum = 0;
      int n = 0;
      for (double a : {0.15, 0.85}) {
        for (double b : {0.15, 0.85}) {
          const cv::Point2d q = (1 - a) * (1 - b) * p00 + a * (1 - b) * p10 + (1 - a) * b * p01 + a * b * p11;
          const double v = SampleBilinear(image, q.x, q.y);
          if (std::isfinite(v)) {
            sum += v;
            ++n;
          }
        }
      }
      if (n > 0) {
        quads.push_back({i, j, sum / n});
        mean += sum / n;
      }
    }
  }
  if (!quads.empty()) mean /= static_cast<double>(quads.size());
  double spread = 0;
  for (const Quad& q : quads) spread += std::abs(q.value - mean);

  // Candidate symmetries: detected (i, j) from board (col, row), keeping the board's size.
  std::vector<Candidate> candidates;
  for (bool transposed : {false, true}) {
    if (transposed ? (w != nr || h != nc) : (w != nc || h != nr)) continue;
    for (bool flip_col : {false, true}) {
      for (bool flip_row : {false, true}) {
        Candidate c;
        c.board_of_detected.assign(static_cast<size_t>(w * h), -1);
        for (int row = 0; row < nr; ++row) {
          for (int col = 0; col < nc; ++col) {
            const int bc = flip_col ? nc - 1 - col : col, br = flip_row ? nr - 1 - row : row;
            const int i = transposed ? br : bc, j = transposed ? bc : br;
            c.board_of_detected[static_cast<size_t>(j * w + i)] = col + row * nc;
          }
        }
        c.name = fmt::format("{}{}{}", transposed ? "T" : "", flip_col ? "C" : "", flip_row ? "R" : "");
        candidates.push_back(std::move(c));
      }
    }
  }
  if (candidates.empty()) {
    out.failure = fmt::format("ambiguous orientation: the detector returned a {}x{} grid for a {}x{} board", w, h, nc, nr);
    return out;
  }
  // Board-ordered points of a candidate, its handedness, colours and up direction.
  std::vector<Candidate> kept;
  for (Candidate& c : candidates) {
    std::vector<cv::Point2d> at(static_cast<size_t>(nc * nr));
    for (size_t d = 0; d < c.board_of_detected.size(); ++d) at[static_cast<size_t>(c.board_of_detected[d])] = grid.px[d];
    const auto p = [&](int col, int row) { return at[static_cast<size_t>(col + row * nc)]; };
    cv::Point2d right(0, 0), down(0, 0);
    for (int row = 0; row < nr; ++row) {
      for (int col = 0; col + 1 < nc; ++col) right += p(col + 1, row) - p(col, row);
    }
    for (int row = 0; row + 1 < nr; ++row) {
      for (int col = 0; col < nc; ++col) down += p(col, row + 1) - p(col, row);
    }
    // Pattern right and down are image x and y for an unmirrored view: right x down > 0; < 0 mirrored.
    const double handed = right.x * down.y - right.y * down.x;
    if (nc >= 2 && nr >= 2 && handed == 0) continue;  // a degenerate grid
    c.mirrored = nc >= 2 && nr >= 2 && handed < 0;
    cv::Point2d up(0, 0);
    if (nc >= 2) up += cv::Point2d(right.y, -right.x) / cv::norm(right) * (c.mirrored ? -1 : 1);
    if (nr >= 2) up -= down / cv::norm(down);
    c.up_deg = std::acos(std::clamp(-up.y / cv::norm(up), -1.0, 1.0)) * 180 / std::numbers::pi;
    double agree = 0;
    for (const Quad& q : quads) {
      int min_col = nc, min_row = nr;
      for (const auto& [di, dj] : kQuadCorners) {
        const int k = c.board_of_detected[static_cast<size_t>((q.j + dj) * w + q.i + di)];
        min_col = std::min(min_col, k % nc);
        min_row = std::min(min_row, k / nc);
      }
      // Square (min_col + 1, min_row + 1) of the board; black where col + row is even (top-left black).
      const bool black = (min_col + min_row) % 2 == 0;
      agree += (black ? -1 : 1) * (q.value - mean);
    }
    c.colour = spread > 0 ? agree / spread : 0;
    kept.push_back(std::move(c));
  }
  if (kept.empty()) {
    out.failure = "ambiguous orientation: the detected grid is degenerate (its rows and columns are parallel)";
    return out;
  }
  // The square colours first, then the upright rule; a mirrored naming only where no unmirrored one is as good
  // (detect.h).
  std::vector<const Candidate*> proper, mirrored;
  for (const Candidate& c : kept) {
    if (quads.empty() || c.colour > 0.5) (c.mirrored ? mirrored : proper).push_back(&c);
  }
  if (proper.empty() && mirrored.empty()) {
    out.failure = "ambiguous orientation: the square colours match no orientation of the pattern (an inverted or "
                  "washed-out photo?)";
    return out;
  }
  out.handedness_from_colours = proper.empty() || mirrored.empty();
  std::vector<const Candidate*> upright_proper, upright_mirrored;
  for (const Candidate* c : proper) {
    if (c->up_deg <= upright_max_deg) upright_proper.push_back(c);
  }
  for (const Candidate* c : mirrored) {
    if (c->up_deg <= upright_max_deg) upright_mirrored.push_back(c);
  }
  const Candidate* chosen = nullptr;
  if (proper.empty()) {
    chosen = MostUpright(mirrored);
    out.note = fmt::format("board orientation from the square colours: they fit mirrored views only (board up "
                           "{:.0f} deg from image up)",
                           chosen->up_deg);
  } else if (upright_proper.size() == 1) {
    chosen = upright_proper.front();
    out.note = proper.size() == 1
                   ? fmt::format("board orientation from the square colours (board up {:.0f} deg from image up)",
                                 chosen->up_deg)
                   : fmt::format("board orientation from the upright rule (board up {:.0f} deg from image up; the "
                                 "square colours leave {} orientations)",
                                 chosen->up_deg, proper.size());
  } else if (upright_proper.empty() && !upright_mirrored.empty()) {
    // E.g. a 16 x 5 board photographed upright through a mirror: its colours are those of the board turned by
    // 180 deg. Upright and mirrored, or turned and unmirrored: the upright rule takes the former.
    chosen = MostUpright(upright_mirrored);
    out.note = fmt::format("board orientation from the upright rule: the square colours fit a mirrored view with "
                           "the board up {:.0f} deg from image up, or an unmirrored one at {} deg",
                           chosen->up_deg, UpAngles(proper));
    out.unmirrored_alternative = fmt::format("an unmirrored photo with the board turned by {} deg", UpAngles(proper));
  } else if (upright_proper.empty() && proper.size() == 1) {
    chosen = proper.front();
    out.note = fmt::format("board orientation from the square colours (board up {:.0f} deg from image up)",
                           chosen->up_deg);
  } else {
    out.failure = fmt::format(
        "ambiguous orientation: the square colours leave {} orientations (board up at {} deg from image up) and "
        "{} of them within {:.0f} deg of upright; hold the camera upright (|roll| < {:.0f} deg)",
        proper.size(), UpAngles(proper), upright_proper.size(), upright_max_deg, upright_max_deg);
    return out;
  }
  out.mirrored = chosen->mirrored;
  out.corner_index = chosen->board_of_detected;
  return out;
}

double AffineHandedness(const std::vector<Eigen::Vector2d>& plane, const std::vector<Eigen::Vector2d>& image) {
  const size_t n = plane.size();
  if (n < 3 || image.size() != n) return std::nan("");
  Eigen::Vector2d mp = Eigen::Vector2d::Zero(), mi = Eigen::Vector2d::Zero();
  for (size_t k = 0; k < n; ++k) {
    mp += plane[k] / static_cast<double>(n);
    mi += image[k] / static_cast<double>(n);
  }
  // image - mi = A (plane - mp): A = (sum q p^T) (sum p p^T)^-1.
  Eigen::Matrix2d pp = Eigen::Matrix2d::Zero(), qp = Eigen::Matrix2d::Zero();
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d p = plane[k] - mp, q = image[k] - mi;
    pp += p * p.transpose();
    qp += q * p.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> spread(pp);
  if (!(spread.eigenvalues()(0) > 1e-12 * spread.eigenvalues()(1))) return std::nan("");  // collinear
  const Eigen::Matrix2d a = qp * pp.inverse();
  const double s1 = Eigen::JacobiSVD<Eigen::Matrix2d>(a).singularValues()(0);
  if (!(s1 > 0) || !a.allFinite()) return std::nan("");
  return a.determinant() / (s1 * s1);
}

std::optional<cv::Size> FindAnyBoardSize(const cv::Mat& gray8) {
  const cv::Mat small = Shrink(gray8, ScaleFactor(gray8, 1600));
  std::vector<cv::Point2f> corners;
  cv::Mat meta;
  if (!cv::findChessboardCornersSB(small, cv::Size(3, 3), corners,
                                   cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_LARGER, meta)) {
    return std::nullopt;
  }
  if (meta.empty()) return std::nullopt;
  return cv::Size(meta.cols, meta.rows);
}

std::optional<CornerGrid> SearchOnClosings(const cv::Mat& gray8,
                                           const std::function<std::optional<CornerGrid>(const cv::Mat&)>& search,
                                           cv::Mat& found_on, int& size_px) {
  for (const int k : {5, 9, 15, 25, 35, 49}) {
    cv::Mat closed;
    cv::morphologyEx(gray8, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
    std::optional<CornerGrid> grid = search(closed);
    if (grid) {
      found_on = closed;
      size_px = k;
      return grid;
    }
  }
  return std::nullopt;
}

GapDeficit MeasureGapDeficit(const cv::Mat& photo, const CornerGrid& grid, double spacing_px) {
  if (grid.px.empty() || !(spacing_px > 0)) return {};
  double x0 = grid.px.front().x, x1 = x0, y0 = grid.px.front().y, y1 = y0;
  for (const cv::Point2d& p : grid.px) {
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  const cv::Point top_left(static_cast<int>(x0 - spacing_px), static_cast<int>(y0 - spacing_px));
  const cv::Point bottom_right(static_cast<int>(x1 + spacing_px) + 1, static_cast<int>(y1 + spacing_px) + 1);
  const int size = std::clamp(2 * static_cast<int>(std::lround(0.25 * spacing_px)) + 1, 3, kGapMeasureSizePx);
  return MeasureGapDeficit(photo, cv::Rect(top_left, bottom_right), size);
}

GapDeficit MeasureGapDeficit(const cv::Mat& photo, cv::Rect within, int size_px) {
  GapDeficit out;
  const int k = size_px;
  out.size_px = k;
  const cv::Rect roi = within & cv::Rect(0, 0, photo.cols, photo.rows);
  if (roi.width < k || roi.height < k) return out;
  cv::Mat closed;
  cv::morphologyEx(photo(roi), closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
  // The white level on every 4th row and 2nd column, the deficit on every 2nd row.
  std::vector<float> levels;
  levels.reserve(static_cast<size_t>(closed.rows / 4 + 1) * static_cast<size_t>(closed.cols / 2 + 1));
  for (int r = 0; r < closed.rows; r += 4) {
    for (int i = 0; i < closed.cols; i += 2) levels.push_back(static_cast<float>(ValueAt(closed, r, i)));
  }
  const double bright = kBrightOfWhite * WhiteLevel(std::move(levels));
  double sum = 0;
  size_t n = 0;
  const cv::Mat area = photo(roi);
  for (int r = 0; r < closed.rows; r += 2) {
    for (int i = 0; i < closed.cols; ++i) {
      const double c = ValueAt(closed, r, i);
      if (bright > 0 && c > bright) sum += (c - ValueAt(area, r, i)) / c, ++n;
    }
  }
  out.deficit = n > 0 ? sum / static_cast<double>(n) : 0;
  out.measured = n > 0;
  return out;
}

}  // namespace curvecheck::detect_internal
