#include "analysis/overlay.h"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <tuple>

#include "analysis/report.h"
#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {

// The image an overlay is drawn on: `gray` (8 or 16 bit) as 8 bit, scaled to at most max_px on its longer side
// with INTER_AREA; and the scale (<= 1).
std::pair<cv::Mat, double> OverlayBase(const cv::Mat& photo_gray, int max_px) {
  cv::Mat gray = photo_gray;
  if (gray.depth() == CV_16U) gray.convertTo(gray, CV_8U, 1.0 / 257);
  const double scale = std::min(1.0, static_cast<double>(max_px) / std::max(gray.cols, gray.rows));
  if (scale >= 1) return {gray.depth() == photo_gray.depth() ? gray.clone() : gray, 1.0};
  cv::Mat small;
  cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
  return {small, scale};
}

namespace {

// Neighbour pairs for drawing the expected grid: checkerboard corners along rows and columns, tag borders.
std::vector<std::pair<std::string, std::string>> GridEdges(const PatternFile& pattern) {
  std::vector<std::pair<std::string, std::string>> edges;
  const nlohmann::json& spec = pattern.raw["pattern"];
  if (spec.contains("cols") && spec.contains("rows") && spec["cols"].is_number_integer() &&
      spec["rows"].is_number_integer()) {
    const int cols = spec["cols"].get<int>() - 1, rows = spec["rows"].get<int>() - 1;
    for (int row = 0; row < rows; ++row) {
      for (int col = 0; col < cols; ++col) {
        const int k = row * cols + col;
        if (col + 1 < cols) edges.push_back({fmt::format("c{}", k), fmt::format("c{}", k + 1)});
        if (row + 1 < rows) edges.push_back({fmt::format("c{}", k), fmt::format("c{}", k + cols)});
      }
    }
  }
  std::set<std::string> tags;
  for (const Feature& f : pattern.features) {
    if (f.kind == "tag_corner") tags.insert(f.id.substr(0, f.id.find('.')));
  }
  for (const std::string& t : tags) {
    for (int k = 0; k < 4; ++k) edges.push_back({fmt::format("{}.{}", t, k), fmt::format("{}.{}", t, (k + 1) % 4)});
  }
  return edges;
}

}  // namespace

namespace {

// The part of segment a-b inside the rectangle [lo, hi] (Liang-Barsky), or nothing. A residual magnified a
// million times is a segment kilometres long in pixels; OpenCV draws such a line in time proportional to its
// length, so it is clipped first.
std::optional<std::pair<Eigen::Vector2d, Eigen::Vector2d>> ClipSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                                                       const Eigen::Vector2d& lo,
                                                                       const Eigen::Vector2d& hi) {
  if (!a.allFinite() || !b.allFinite()) return std::nullopt;
  double t0 = 0, t1 = 1;
  const Eigen::Vector2d d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    const double p[2] = {-d[axis], d[axis]};
    const double q[2] = {a[axis] - lo[axis], hi[axis] - a[axis]};
    for (int k = 0; k < 2; ++k) {
      if (p[k] == 0) {
        if (q[k] < 0) return std::nullopt;
        continue;
      }
      const double t = q[k] / p[k];
      if (p[k] < 0) {
        t0 = std::max(t0, t);
      } else {
        t1 = std::min(t1, t);
      }
    }
  }
  if (t0 > t1) return std::nullopt;
  return std::make_pair(Eigen::Vector2d(a + t0 * d), Eigen::Vector2d(a + t1 * d));
}

}  // namespace

std::string OverlayPng(const AnalysisResult& r, size_t i, double magnification, int max_px) {
  const int source = r.OverlaySource(i);
  if (source < 0) throw Error(r.photos.at(i).name, "has no overlay (the photo was not used)", "this is a bug");
  // A duplicate is drawn with the analysis of the earlier photo with its content (the same pixels), under its own
  // name.
  const PhotoAnalysis& p = r.photos[static_cast<size_t>(source)];
  const std::string& name = r.photos[i].name;
  // The image kept by the analysis (no second decode), else the photo read again.
  cv::Mat small;
  double scale = 1;
  if (!p.overlay_gray.empty() && p.overlay_max_px == max_px) {
    small = p.overlay_gray;
    scale = p.overlay_scale;
  } else {
    std::tie(small, scale) = OverlayBase(ReadPhotoGray(p.input.photo), max_px);
  }
  const cv::Size photo_size(r.camera.width, r.camera.height);  // a used photo has the camera model's size
  cv::Mat img;
  cv::cvtColor(small, img, cv::COLOR_GRAY2BGR);
  // Pixel centres at integers in both images: x_small = (x + 0.5) scale - 0.5.
  const auto at = [&](const Eigen::Vector2d& q) {
    return cv::Point2d((q.x() + 0.5) * scale - 0.5, (q.y() + 0.5) * scale - 0.5);
  };
  const int thick = std::max(1, static_cast<int>(std::lround(std::max(img.cols, img.rows) / 1500.0)));
  // A vector from q to q + m v in photo pixels, drawn as far as it is inside the image (plus a margin for the
  // line's width).
  const Eigen::Vector2d margin(4.0 * thick / scale, 4.0 * thick / scale);
  const Eigen::Vector2d lo = Eigen::Vector2d(-0.5, -0.5) - margin;
  const Eigen::Vector2d hi = Eigen::Vector2d(photo_size.width - 0.5, photo_size.height - 0.5) + margin;
  const auto vector = [&](const Eigen::Vector2d& q, const Eigen::Vector2d& v, const cv::Scalar& colour) {
    if (const auto s = ClipSegment(q, q + magnification * v, lo, hi)) {
      cv::line(img, at(s->first), at(s->second), colour, thick + 1, cv::LINE_AA);
    }
  };
  std::map<std::string, const FeatureCheck*> checks;
  for (const FeatureCheck& c : p.verification.features) checks[c.id] = &c;
  for (const auto& [a, b] : GridEdges(r.patterns[static_cast<size_t>(source)])) {
    const auto ca = checks.find(a), cb = checks.find(b);
    if (ca == checks.end() || cb == checks.end()) continue;
    cv::line(img, at(ca->second->expected_px), at(cb->second->expected_px), cv::Scalar(0, 160, 0), thick,
             cv::LINE_AA);
  }
  for (const FeatureCheck& c : p.verification.features) {
    vector(c.expected_px, c.residual_px, cv::Scalar(0, 0, 255));
    cv::circle(img, at(c.expected_px), 2 * thick, cv::Scalar(0, 160, 0), thick, cv::LINE_AA);
  }
  if (r.fit && p.fit_index >= 0) {
    const ModelFit& chosen = r.fit->Chosen();
    const auto& res = chosen.residual_px[static_cast<size_t>(p.fit_index)];
    std::map<std::string, Eigen::Vector2d> detected;
    for (const DetectedFeature& d : p.detection.features) detected[d.id] = d.px;
    for (size_t k = 0; k < p.fit_ids.size() && k < res.size(); ++k) {
      vector(detected[p.fit_ids[k]], res[k], cv::Scalar(255, 80, 0));
    }
  }
  const std::string legend = fmt::format(
      "{}: green = expected planar perspective grid; red = verification residual x{:g}; blue = {} fit residual x{:g}",
      name, magnification, r.fit ? r.fit->Chosen().model : std::string("(no)"), magnification);
  const double font = std::max(0.5, img.cols / 2500.0);
  cv::putText(img, legend, cv::Point(10, static_cast<int>(30 * font)), cv::FONT_HERSHEY_SIMPLEX, font,
              cv::Scalar(0, 255, 255), thick, cv::LINE_AA);
  if (source != static_cast<int>(i)) {
    const std::string mark = fmt::format("{}: duplicate of {} (the same image content), not used in the fit", name,
                                         p.input.photo.string());
    cv::putText(img, mark, cv::Point(10, static_cast<int>(75 * font)), cv::FONT_HERSHEY_SIMPLEX, 1.5 * font,
                cv::Scalar(255, 0, 255), 2 * thick, cv::LINE_AA);
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", img, png)) throw Error(OverlayFileName(name), "could not encode the overlay image");
  return std::string(reinterpret_cast<const char*>(png.data()), png.size());
}

std::vector<std::filesystem::path> WriteOverlays(const AnalysisResult& r, const std::filesystem::path& dir,
                                                 double magnification, int max_px) {
  std::vector<std::filesystem::path> written;
  for (size_t i = 0; i < r.photos.size(); ++i) {
    if (r.OverlaySource(i) < 0) continue;
    const std::filesystem::path out = dir / OverlayFileName(r.photos[i].name);
    WriteFileAtomic(out, OverlayPng(r, i, magnification, max_px));
    written.push_back(out);
  }
  return written;
}

}  // namespace curvecheck
