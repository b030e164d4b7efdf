#include "render/pattern_texture.h"

#include "core/monitor_json.h"

namespace curvecheck {
namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

Eigen::Vector3d PatternQuad::PointFromTexturePx(const Eigen::Vector2d& t) const {
  const double fx = (t.x() + 0.5) / width_px, fy = (t.y() + 0.5) / height_px;  // 0..1 from the top-left edge
  return top_left_in_screen + fx * (top_right_in_screen - top_left_in_screen) +
         fy * (bottom_left_in_screen - top_left_in_screen);
}

Monitor PatternQuad::AsFlatMonitor() const {
  Monitor m;
  m.name = "the texture's quad (chord plane)";
  m.width_px = width_px;
  m.height_px = height_px;
  m.width_mm = width_mm;
  m.height_mm = height_mm;
  m.curvature_per_mm = 0;
  return m;
}

PatternQuad MakePatternQuad(const Monitor& m, const Eigen::Vector3d& viewpoint) {
  PatternQuad q;
  q.frustum = MakeOffAxisFrustum(m, viewpoint);
  const OffAxisFrustum& f = q.frustum;
  q.width_px = m.width_px;
  q.height_px = m.height_px;
  q.width_mm = f.right_mm - f.left_mm;
  q.height_mm = f.top_mm - f.bottom_mm;
  // The near plane at distance n in front of the eye (-z), extents relative to the eye (thesis Eq 4.5).
  const double z = viewpoint.z() - f.near_mm;
  auto at = [&](double x, double y) { return Eigen::Vector3d(viewpoint.x() + x, viewpoint.y() + y, z); };
  q.top_left_in_screen = at(f.left_mm, f.top_mm);
  q.top_right_in_screen = at(f.right_mm, f.top_mm);
  q.bottom_right_in_screen = at(f.right_mm, f.bottom_mm);
  q.bottom_left_in_screen = at(f.left_mm, f.bottom_mm);
  q.centre_in_screen = at(0.5 * (f.left_mm + f.right_mm), 0.5 * (f.bottom_mm + f.top_mm));
  return q;
}

GrayImage RenderPatternTexture(Renderer& renderer, const PatternQuad& quad, const Eigen::Vector3d& viewpoint,
                               const Pattern& pattern, const RenderOptions& options) {
  // The quad as a flat display: its screen frame is the screen frame moved to the quad's centre (a flat
  // monitor's screen is z = 0 there), so the viewpoint and the pattern plane move with it.
  Pattern moved = pattern;
  moved.plane.origin_in_screen -= quad.centre_in_screen;
  for (Feature& f : moved.features) f.point_in_screen -= quad.centre_in_screen;
  RenderOptions exact = options;
  exact.method.method = Method::kExact;
  return renderer.Render(quad.AsFlatMonitor(), viewpoint - quad.centre_in_screen, moved, exact);
}

nlohmann::json PlaneToJson(const PatternQuad& q, const Monitor& m, const Eigen::Vector3d& viewpoint,
                           const RenderOptions& options, const std::string& texture_file) {
  nlohmann::json j;
  j["format"] = "curvecheck.plane/1";
  j["frame"] =
      "screen frame (mm): origin on the cylinder axis at the height of the screen's vertical centre (the screen centre "
      "for a flat monitor), x right, y up, +z toward the viewer; the screen centre is at (0, 0, -R)";
  j["monitor"] = MonitorToJson(m);
  j["eye_mm"] = Vec(viewpoint);
  j["plane"] = {{"z_mm", q.top_left_in_screen.z()},
                {"normal", {0, 0, 1}},
                {"what", "the near plane of the off-axis frustum: the chord plane through the display's four corners "
                         "(thesis Eq 4.5, vertical extents widened per 4.2.2)"}};
  j["frustum"] = {{"left_mm", q.frustum.left_mm},     {"right_mm", q.frustum.right_mm},
                  {"bottom_mm", q.frustum.bottom_mm}, {"top_mm", q.frustum.top_mm},
                  {"near_mm", q.frustum.near_mm},     {"vertical_extents_widened", q.frustum.vertical_extents_widened}};
  j["texture"] = {{"file", texture_file},
                  {"size_px", {q.width_px, q.height_px}},
                  {"texel_mm", {q.width_mm / q.width_px, q.height_mm / q.height_px}},
                  {"rows", "the PNG's first row is the quad's top edge (largest y); texel (i, j) has its centre at "
                           "(i, j), the image's edges at -0.5 and size - 0.5"},
                  {"encoding", "8-bit gray code values, anti-aliased in linear light: code = 255 linear^(1/gamma)"},
                  {"gamma", options.display_gamma},
                  {"surround_code", options.surround_code}};
  nlohmann::json corners = nlohmann::json::array();
  struct C {
    const char* name;
    Eigen::Vector3d p;
    double u, v;  // v down
  };
  for (const C& c : {C{"top_left", q.top_left_in_screen, 0, 0}, C{"top_right", q.top_right_in_screen, 1, 0},
                     C{"bottom_right", q.bottom_right_in_screen, 1, 1},
                     C{"bottom_left", q.bottom_left_in_screen, 0, 1}}) {
    corners.push_back({{"corner", c.name},
                       {"in_screen_mm", Vec(c.p)},
                       {"from_eye_mm", Vec(c.p - viewpoint)},
                       {"uv_v_down", {c.u, c.v}},
                       {"uv_v_up", {c.u, 1 - c.v}}});
  }
  j["corners"] = corners;
  j["how_to_draw"] =
      "Place a rectangle with these four corners (screen frame, or from_eye_mm in a camera frame at the eye with the "
      "screen frame's axes) and texture it with the PNG: uv_v_down where v = 0 is the PNG's first row as stored "
      "(Vulkan, Direct3D, Metal; OpenGL when the rows are uploaded as stored), uv_v_up where the loader flips rows so "
      "that v = 0 is the last row (OpenGL with a flipped upload). Seen from the eye the quad shows the pattern as the "
      "curved display must show it after your correction; pattern.json has every feature's exact display position.";
  j["command"] = "curvecheck pattern";
  return j;
}

}  // namespace curvecheck
