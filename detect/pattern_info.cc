#include "detect/pattern_info.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>

#include "core/error.h"

namespace curvecheck::detect_internal {

PatternInfo ReadPatternInfo(const PatternFile& pattern) {
  const nlohmann::json& p = pattern.raw.at("pattern");
  const auto fail = [](const std::string& what) {
    throw Error("pattern.json", what, "write it again with curvecheck render");
  };
  PatternInfo info;
  if (!p.contains("kind") || !p.at("kind").is_string()) fail("'pattern.kind' is missing or not a text");
  info.kind = p.at("kind").get<std::string>();
  if (info.kind != "checkerboard" && info.kind != "apriltag" && info.kind != "both") {
    fail(fmt::format("'pattern.kind' is '{}', not checkerboard, apriltag or both", info.kind));
  }
  if (info.kind != "apriltag") {
    for (const char* key : {"cols", "rows"}) {
      if (!p.contains(key) || !p.at(key).is_number_integer() || p.at(key).get<int>() < 2) {
        fail(fmt::format("'pattern.{}' is missing or not a whole number of at least 2", key));
      }
    }
    info.cols = p.at("cols").get<int>();
    info.rows = p.at("rows").get<int>();
    if (!p.contains("square_mm") || !p.at("square_mm").is_number() || !(p.at("square_mm").get<double>() > 0)) {
      fail("'pattern.square_mm' is missing or not positive");
    }
    info.square_mm = p.at("square_mm").get<double>();
  }
  for (const Feature& f : pattern.features) {
    info.pattern_mm[f.id] = f.pattern_mm;
    if (f.kind == "tag_corner") {
      info.tag_ids.insert(std::stoi(f.id.substr(1)));
      ++info.tag_corners;
    } else {
      ++info.board_corners;
    }
  }
  if (info.kind != "apriltag" && info.board_corners != (info.cols - 1) * (info.rows - 1)) {
    fail(fmt::format("has {} checkerboard corners, but a board of {}x{} squares has {}", info.board_corners,
                     info.cols, info.rows, (info.cols - 1) * (info.rows - 1)));
  }
  if (info.kind != "checkerboard" && info.tag_ids.empty()) fail("is a pattern with tags but lists no tag corners");
  return info;
}

std::string TagIdRanges(const std::set<int>& ids) {
  std::string out;
  for (auto it = ids.begin(); it != ids.end();) {
    const int first = *it;
    int last = first;
    for (++it; it != ids.end() && *it == last + 1; ++it) last = *it;
    out += fmt::format("{}{}", out.empty() ? "" : ", ", first == last ? fmt::format("{}", first)
                                                                     : fmt::format("{}..{}", first, last));
  }
  return out;
}

std::optional<Eigen::Matrix3d> FitHomography(const std::vector<Eigen::Vector2d>& from,
                                             const std::vector<Eigen::Vector2d>& to) {
  const size_t n = from.size();
  if (n < 4) return std::nullopt;
  const auto normalizer = [](const std::vector<Eigen::Vector2d>& pts) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : pts) mean += p;
    mean /= static_cast<double>(pts.size());
    double spread = 0;
    for (const auto& p : pts) spread += (p - mean).norm();
    spread /= static_cast<double>(pts.size());
    const double s = spread > 0 ? std::sqrt(2.0) / spread : 1.0;
    Eigen::Matrix3d t;
    t << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
    return t;
  };
  const Eigen::Matrix3d ta = normalizer(from), tb = normalizer(to);
  Eigen::Matrix<double, 8, 8> ata = Eigen::Matrix<double, 8, 8>::Zero();
  Eigen::Matrix<double, 8, 1> atb = Eigen::Matrix<double, 8, 1>::Zero();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = ta * from[i].homogeneous(), q = tb * to[i].homogeneous();
    Eigen::Matrix<double, 8, 1> r1, r2;
    r1 << p.x(), p.y(), 1, 0, 0, 0, -q.x() * p.x(), -q.x() * p.y();
    r2 << 0, 0, 0, p.x(), p.y(), 1, -q.y() * p.x(), -q.y() * p.y();
    ata += r1 * r1.transpose() + r2 * r2.transpose();
    atb += r1 * q.x() + r2 * q.y();
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(ata);
  if (lu.rank() < 8 || lu.rcond() < 1e-12) return std::nullopt;
  const Eigen::Matrix<double, 8, 1> h = lu.solve(atb);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1;
  const Eigen::Matrix3d out = tb.inverse() * hn * ta;
  if (!out.allFinite()) return std::nullopt;
  return out;
}

Eigen::Vector2d ApplyHomography(const Eigen::Matrix3d& h, const Eigen::Vector2d& p) {
  return (h * p.homogeneous()).hnormalized();
}

}  // namespace curvecheck::detect_internal
