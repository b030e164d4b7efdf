#include "pattern/pattern_json.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <set>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_hash.h"
#include "core/monitor_json.h"
#include "core/screen_geometry.h"
#include "pattern/feature_id.h"

namespace curvecheck {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "curvecheck.pattern/1";
constexpr int kTag36h11Codes = 587;
constexpr const char* kRerender = "write it again with curvecheck render";

template <typename Derived>
json Array(const Eigen::MatrixBase<Derived>& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
  return a;
}

json SpecToJson(const Pattern& p) {
  const PatternSpec& s = p.spec;
  json j;
  j["kind"] = PatternKindName(s.kind);
  if (s.kind != PatternKind::kAprilTag) {
    j["cols"] = s.cols;
    j["rows"] = s.rows;
    j["square_mm"] = s.square_mm;
  }
  if (s.kind == PatternKind::kAprilTag) {
    j["tag_cols"] = s.tag_cols;
    j["tag_rows"] = s.tag_rows;
    j["tag_gap_cells"] = s.tag_gap_cells;
  }
  if (s.kind != PatternKind::kCheckerboard) {
    j["tag_family"] = "tag36h11";
    j["tag_mm"] = s.tag_mm;
    j["first_tag_id"] = s.first_tag_id;
    // The ids in the order they are placed (row-major from the top left), from the tags' first corners.
    json ids = json::array();
    for (const Feature& f : p.features) {
      if (f.kind == "tag_corner" && f.id.ends_with(".0")) ids.push_back(std::stoi(f.id.substr(1)));
    }
    j["tag_ids"] = ids;
  }
  j["margin"] = s.margin;
  j["centre_mm"] = Array(s.centre_mm);
  j["plane"] = {{"origin_mm", Array(p.plane.origin_in_screen)},
                {"x_axis", Array(p.plane.x_axis_in_screen)},
                {"y_axis", Array(p.plane.y_axis_in_screen)}};
  j["cells"] = {{"cell_mm", p.cells.cell_mm},
                {"top_left_mm", Array(p.cells.top_left_mm)},
                {"width", p.cells.width},
                {"height", p.cells.height}};
  return j;
}

// Strict access to one document; every failure names the file and the JSON path of the entry.
class Reader {
 public:
  explicit Reader(std::filesystem::path path) : path_(std::move(path)) {}

  [[noreturn]] void Fail(const std::string& at, const std::string& problem,
                         const std::string& fix = kRerender) const {
    throw Error(path_.string(), at.empty() ? problem : fmt::format("'{}' {}", at, problem), fix);
  }

  const json& Member(const json& object, const std::string& at, const char* key) const {
    const std::string here = at.empty() ? key : at + "." + key;
    if (!object.contains(key)) Fail(here, "is missing");
    return object.at(key);
  }

  const json& Object(const json& v, const std::string& at) const {
    if (!v.is_object()) Fail(at, fmt::format("must be an object, got {}", Show(v)));
    return v;
  }

  std::string String(const json& v, const std::string& at) const {
    if (!v.is_string()) Fail(at, fmt::format("must be a text, got {}", Show(v)));
    return v.get<std::string>();
  }

  double Number(const json& v, const std::string& at) const {
    if (!v.is_number()) Fail(at, fmt::format("must be a number, got {}", Show(v)));
    const double d = v.get<double>();
    if (!std::isfinite(d)) Fail(at, fmt::format("is {}, not a finite number", d));
    return d;
  }

  int PositiveInt(const json& v, const std::string& at) const {
    if (!v.is_number_integer() || v.get<double>() < 1 || v.get<double>() > 1e9) {
      Fail(at, fmt::format("must be a whole number of at least 1, got {}", Show(v)));
    }
    return v.get<int>();
  }

  template <int N>
  Eigen::Matrix<double, N, 1> Vector(const json& v, const std::string& at) const {
    if (!v.is_array() || v.size() != N)
      Fail(at, fmt::format("must be a list of {} numbers, got {}", N, Show(v)));
    Eigen::Matrix<double, N, 1> out;
    for (int i = 0; i < N; ++i) out(i) = Number(v[i], fmt::format("{}[{}]", at, i));
    return out;
  }

  // Every number anywhere in the document is finite (the parser already refuses NaN and overflow; this
  // keeps the promise independent of the parser), and nothing is nested deeper than kMaxDepth: a pattern.json
  // nests 4 levels; without the limit a 20 kB file of nested lists overflowed the stack here (recursion, and
  // a path string per level).
  static constexpr int kMaxDepth = 32;
  void CheckFinite(const json& v, const std::string& at, int depth = 0) const {
    if (depth > kMaxDepth) Fail(at, fmt::format("is nested more than {} levels deep", kMaxDepth));
    if (v.is_number_float() && !std::isfinite(v.get<double>())) Fail(at, "is not a finite number");
    if (v.is_object()) {
      for (const auto& [key, value] : v.items()) CheckFinite(value, at.empty() ? key : at + "." + key, depth + 1);
    } else if (v.is_array()) {
      for (size_t i = 0; i < v.size(); ++i) CheckFinite(v[i], fmt::format("{}[{}]", at, i), depth + 1);
    }
  }

  static std::string Show(const json& v) {
    std::string s = v.dump();
    if (s.size() > 40) s = s.substr(0, 37) + "...";
    return s;
  }

 private:
  std::filesystem::path path_;
};

// A decimal count without sign or leading zeros, below `limit`.
bool ParseCount(std::string_view text, long limit, long& out) {
  if (text.empty() || text.size() > 10 || (text.size() > 1 && text[0] == '0')) return false;
  if (!std::all_of(text.begin(), text.end(), [](char ch) { return ch >= '0' && ch <= '9'; })) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size() && out < limit;
}

// "c<k>" (kind "corner") or "t<id>.<k>" with id < 587 and k in 0..3 (kind "tag_corner"); else "" .
std::string KindOfId(const std::string& id) {
  long n = 0;
  if (CornerIndexOfId(id)) return "corner";
  const size_t dot = id.find('.');
  if (id.size() >= 4 && id[0] == 't' && dot != std::string::npos &&
      ParseCount(std::string_view(id).substr(1, dot - 1), kTag36h11Codes, n) &&
      ParseCount(std::string_view(id).substr(dot + 1), 4, n)) {
    return "tag_corner";
  }
  return "";
}

Monitor ReadMonitor(const Reader& r, const json& root, const std::filesystem::path& path) {
  const json& mj = r.Object(r.Member(root, "", "monitor"), "monitor");
  const std::string name = mj.contains("name") ? r.String(mj.at("name"), "monitor.name") : path.string();
  const json& res = r.Member(mj, "monitor", "resolution");
  if (!res.is_array() || res.size() != 2) {
    r.Fail("monitor.resolution", fmt::format("must be [Nx, Ny], got {}", Reader::Show(res)));
  }
  const int nx = r.PositiveInt(res[0], "monitor.resolution[0]");
  const int ny = r.PositiveInt(res[1], "monitor.resolution[1]");
  const double width_mm = r.Number(r.Member(mj, "monitor", "width_mm"), "monitor.width_mm");
  const double height_mm = r.Number(r.Member(mj, "monitor", "height_mm"), "monitor.height_mm");
  const json& radius = r.Member(mj, "monitor", "radius_mm");
  double radius_mm = 0;  // flat
  if (!(radius.is_string() && radius.get<std::string>() == "flat")) {
    radius_mm = r.Number(radius, "monitor.radius_mm");
    if (!(radius_mm > 0))
      r.Fail("monitor.radius_mm", fmt::format("is {}; it must be positive or \"flat\"", radius_mm));
  }
  Monitor m = MonitorFromActiveArea(name, nx, ny, width_mm, height_mm, radius_mm);
  m.Check(path.string());
  return m;
}

Feature ReadFeature(const Reader& r, const json& fj, const std::string& at) {
  r.Object(fj, at);
  Feature f;
  f.id = r.String(r.Member(fj, at, "id"), at + ".id");
  const std::string kind_of_id = KindOfId(f.id);
  if (kind_of_id.empty()) {
    r.Fail(at + ".id", fmt::format("is '{}', not a feature id", f.id),
           "ids are c<k> (checkerboard corners) or t<tag>.<0..3> (tag corners, tag < 587)");
  }
  f.kind = r.String(r.Member(fj, at, "kind"), at + ".kind");
  if (f.kind != kind_of_id) {
    r.Fail(at + ".kind", fmt::format("is '{}', but feature '{}' is a {}", f.kind, f.id, kind_of_id));
  }
  f.pattern_mm = r.Vector<2>(r.Member(fj, at, "pattern_mm"), at + ".pattern_mm");
  f.point_in_screen = r.Vector<3>(r.Member(fj, at, "point_mm"), at + ".point_mm");
  const json& px = r.Member(fj, at, "display_px");
  if (!px.is_null()) f.display_px = r.Vector<2>(px, at + ".display_px");
  const json& visible = r.Member(fj, at, "visible");
  if (!visible.is_boolean())
    r.Fail(at + ".visible", fmt::format("must be true or false, got {}", Reader::Show(visible)));
  f.visible = visible.get<bool>();
  if (f.visible && !f.display_px) r.Fail(at, "is visible but has no display_px");
  return f;
}

}  // namespace

nlohmann::json PatternToJson(const Pattern& p, const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                             const nlohmann::json& method) {
  if (!method.is_object() || !method.contains("name") || !method.at("name").is_string()) {
    throw Error("PatternToJson", "the method must be an object with a text 'name', got " + method.dump(),
                "pass e.g. {\"name\": \"exact\", ...}");
  }
  json j;
  j["format"] = kFormat;
  j["monitor"] = MonitorToJson(m);
  j["viewpoint_mm"] = Array(viewpoint_in_screen);
  j["method"] = method.at("name");
  j["method_parameters"] = method;
  j["pattern"] = SpecToJson(p);
  json features = json::array();
  for (const Feature& f : p.features) {
    features.push_back({{"id", f.id},
                        {"kind", f.kind},
                        {"pattern_mm", Array(f.pattern_mm)},
                        {"point_mm", Array(f.point_in_screen)},
                        {"display_px", f.display_px ? Array(*f.display_px) : json(nullptr)},
                        {"visible", f.visible}});
  }
  j["features"] = std::move(features);
  return j;
}

PatternFile ReadPatternJson(const std::filesystem::path& path) {
  return ParsePatternJson(ReadFileToString(path), path.string());
}

PatternFile ParsePatternJson(const std::string& text, const std::string& source) {
  const std::filesystem::path path(source);
  const Reader r(path);
  PatternFile out;
  try {
    out.raw = json::parse(text);
  } catch (const json::exception& e) {
    r.Fail("", fmt::format("is not valid JSON ({})", e.what()),
           "the file is damaged or truncated; " + std::string(kRerender));
  }
  const json& root = r.Object(out.raw, "(top level)");
  r.CheckFinite(root, "");

  const json& format = r.Member(root, "", "format");
  if (!format.is_string() || format.get<std::string>() != kFormat) {
    r.Fail("format", fmt::format("is {}, not \"{}\"", Reader::Show(format), kFormat),
           "this version reads curvecheck.pattern/1 files written by curvecheck render");
  }
  out.monitor = ReadMonitor(r, root, path);
  out.viewpoint_in_screen = r.Vector<3>(r.Member(root, "", "viewpoint_mm"), "viewpoint_mm");
  CheckViewpoint(out.monitor, out.viewpoint_in_screen, path.string());
  out.method = r.String(r.Member(root, "", "method"), "method");
  if (out.method.empty()) r.Fail("method", "is empty");
  r.Object(r.Member(root, "", "pattern"), "pattern");

  const json& features = r.Member(root, "", "features");
  if (!features.is_array() || features.empty()) {
    r.Fail("features", fmt::format("must be a non-empty list, got {}", Reader::Show(features)));
  }
  std::set<std::string> ids;
  for (size_t i = 0; i < features.size(); ++i) {
    Feature f = ReadFeature(r, features[i], fmt::format("features[{}]", i));
    if (!ids.insert(f.id).second)
      r.Fail(fmt::format("features[{}].id", i), fmt::format("'{}' appears twice", f.id));
    out.features.push_back(std::move(f));
  }
  return out;
}

std::string DisplayImageHash(const Image8& image) {
  const int n = image.width * image.height, c = image.channels;
  std::vector<uint8_t> gray;
  bool is_gray = c == 1;
  if (c >= 3) {  // equal B, G, R in every pixel: the same picture as a gray image
    gray.resize(static_cast<size_t>(n));
    is_gray = true;
    for (int i = 0; i < n && is_gray; ++i) {
      const uint8_t* px = &image.pixels[static_cast<size_t>(i) * c];
      is_gray = px[0] == px[1] && px[1] == px[2];
      gray[static_cast<size_t>(i)] = px[0];
    }
  }
  const uint8_t* data = c == 1 ? image.pixels.data() : is_gray ? gray.data() : image.pixels.data();
  const cv::Mat mat(image.height, image.width, CV_8UC(is_gray ? 1 : c), const_cast<uint8_t*>(data));
  return HashImageContent(mat).Hex();
}

void CheckPatternBelongsToImage(const PatternFile& pattern, const std::filesystem::path& pattern_json,
                                const std::filesystem::path& image_path, const Image8& image) {
  const json& render = pattern.raw.contains("render") ? pattern.raw["render"] : json();
  if (!render.is_object()) return;
  const std::string recorded = render.contains("image") && render["image"].is_string() ? render["image"].get<std::string>() : "";
  const std::string fix = fmt::format(
      "give the display PNG together with the .json that `curvecheck render` wrote beside it (render again if it "
      "is lost)");
  if (render.contains("image_content_hash") && render["image_content_hash"].is_string()) {
    const std::string hash = DisplayImageHash(image);
    if (hash == render["image_content_hash"].get<std::string>()) return;
    throw Error(pattern_json.string(),
                fmt::format("was written for another image than {} ({}): its render.image_content_hash is {}, the "
                            "image's is {}",
                            image_path.string(), recorded.empty() ? "render.image not recorded"
                                                                  : fmt::format("render.image is '{}'", recorded),
                            render["image_content_hash"].get<std::string>().substr(0, 16), hash.substr(0, 16)),
                fix);
  }
  if (!recorded.empty() && recorded != image_path.filename().string()) {
    throw Error(pattern_json.string(),
                fmt::format("was written for the image '{}' (render.image), not for {}", recorded, image_path.string()),
                fix);
  }
}

}  // namespace curvecheck
