#include "pattern/board.h"

#include <fmt/format.h>

#include <cmath>
#include <regex>

#include "core/error.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

std::vector<Eigen::Vector3d> BoardSpec::CornersInBoard() const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<size_t>(corner_count()));
  for (int r = 0; r < corners_y; ++r) {
    for (int c = 0; c < corners_x; ++c) out.emplace_back(c * square_mm, r * square_mm, 0);
  }
  return out;
}

void BoardSpec::Check(const std::string& where) const {
  if (corners_x < 2 || corners_y < 2) {
    throw Error(where, fmt::format("a {}x{} board has too few inner corners", corners_x, corners_y),
                "count the inner corners (where four squares meet): e.g. 9x6 for a board of 10x7 squares");
  }
  if (!std::isfinite(square_mm) || square_mm <= 0) {
    throw Error(where, fmt::format("square size {} mm is not a positive number", square_mm),
                "give the edge of one square in mm, measured on the printed or displayed board");
  }
}

BoardSpec BoardFromText(const std::string& size_text, double square_mm) {
  static const std::regex kSize(R"(^\s*(\d+)\s*[xX]\s*(\d+)\s*$)");
  std::smatch m;
  if (!std::regex_match(size_text, m, kSize)) {
    throw Error("--board", fmt::format("'{}' is not of the form NxM", size_text),
                "give the inner corners across and down, e.g. --board 9x6");
  }
  BoardSpec b;
  b.corners_x = std::stoi(m[1].str());
  b.corners_y = std::stoi(m[2].str());
  b.square_mm = 1;
  b.Check("--board");
  b.square_mm = square_mm;
  b.Check("--square-mm");
  b.source = fmt::format("--board {} --square-mm {}", size_text, square_mm);
  return b;
}

BoardSpec BoardFromPatternJson(const std::filesystem::path& path) {
  const PatternFile p = ReadPatternJson(path);
  const std::string where = path.string();
  if (!p.monitor.is_flat()) {
    throw Error(where, fmt::format("was rendered for a curved monitor ({})", DescribeRadius(p.monitor)),
                "a calibration target must be flat: render the checkerboard for a flat monitor");
  }
  const nlohmann::json& pat = p.raw.at("pattern");
  const std::string kind = pat.value("kind", "");
  if (kind != "checkerboard") {
    throw Error(where, fmt::format("holds a '{}' pattern, not a plain checkerboard", kind),
                "render with --pattern checkerboard");
  }
  BoardSpec b;
  b.corners_x = pat.at("cols").get<int>() - 1;
  b.corners_y = pat.at("rows").get<int>() - 1;
  b.square_mm = pat.at("square_mm").get<double>();
  b.Check(where);
  // Corner ids c<k>, k = row * corners_x + col: all present, on the screen plane (z = 0 for a flat monitor),
  // spaced by square_mm. A plane other than the screen would make the displayed squares another size.
  std::vector<const Feature*> corners(static_cast<size_t>(b.corner_count()), nullptr);
  for (const Feature& f : p.features) {
    if (f.kind != "corner") continue;
    const int k = std::stoi(f.id.substr(1));
    if (k >= 0 && k < b.corner_count()) corners[static_cast<size_t>(k)] = &f;
  }
  for (int k = 0; k < b.corner_count(); ++k) {
    const Feature* f = corners[static_cast<size_t>(k)];
    if (!f || !f->visible) {
      throw Error(where, fmt::format("corner c{} is missing or off the display", k),
                  "render the checkerboard so that it lies wholly on the display");
    }
    if (std::abs(f->point_in_screen.z()) > 1e-6) {
      throw Error(where, fmt::format("corner c{} lies {:.3f} mm off the screen plane", k, f->point_in_screen.z()),
                  "render on the default plane (the screen itself for a flat monitor)");
    }
  }
  const double spacing = (corners[1]->point_in_screen - corners[0]->point_in_screen).norm();
  if (std::abs(spacing - b.square_mm) > 1e-6 * b.square_mm) {
    throw Error(where, fmt::format("corners c0 and c1 are {} mm apart but square_mm is {}", spacing, b.square_mm),
                "re-render the pattern; the file is inconsistent");
  }
  b.source = where;
  return b;
}

}  // namespace curvecheck
