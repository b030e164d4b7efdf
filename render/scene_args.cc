#include "render/scene_args.h"

#include <fmt/format.h>

#include <cstdio>

#include "core/config.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/viewing.h"
#include "datasets/monitor_presets.h"

namespace curvecheck {

std::pair<int, int> ParseCount2(const std::string& text, const std::string& option) {
  int a = 0, b = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &a, &x, &b, &extra) != 3 || (x != 'x' && x != 'X')) {
    throw Error(option, fmt::format("'{}' is not of the form CxR", text), "write e.g. 16x5");
  }
  return {a, b};
}

Scene ResolveScene(const SceneArgs& a, const Eigen::Vector3d& default_from_centre) {
  Scene s;
  s.monitor = LoadMonitor(a.monitor);
  const std::optional<Eigen::Vector3d> given = ViewpointFromOptions(s.monitor, a.viewpoint, a.distance_mm, a.offset_mm);
  s.viewpoint_in_screen = given ? *given : ScreenCentreInScreen(s.monitor) + default_from_centre;
  CheckViewpoint(s.monitor, s.viewpoint_in_screen, "--viewpoint");
  if (a.pattern_file) s.spec = PatternSpecFromConfig(ConfigMap::Load(*a.pattern_file));
  s.spec.kind = ParsePatternKind(a.pattern, "--pattern");
  if (a.squares) std::tie(s.spec.cols, s.spec.rows) = ParseCount2(*a.squares, "--squares");
  if (a.tags) std::tie(s.spec.tag_cols, s.spec.tag_rows) = ParseCount2(*a.tags, "--tags");
  if (a.square_mm) s.spec.square_mm = *a.square_mm;
  if (a.tag_mm) s.spec.tag_mm = *a.tag_mm;
  if (a.margin) s.spec.margin = *a.margin;
  if (a.first_tag_id) s.spec.first_tag_id = *a.first_tag_id;
  if (a.tag_gap_cells) s.spec.tag_gap_cells = *a.tag_gap_cells;
  s.spec.Check("pattern options");
  return s;
}

RenderOptions ResolveMethod(const MethodArgs& a) {
  RenderOptions o;
  MethodOptions& m = o.method;
  m.method = ParseMethod(a.method, "--method");
  if (a.aa == "analytic") {
    m.antialiasing = AntiAliasing::kAnalytic;
  } else if (a.aa.rfind("ss", 0) == 0) {
    m.antialiasing = AntiAliasing::kSupersample;
    try {
      m.supersample = std::stoi(a.aa.substr(2));
    } catch (const std::exception&) {
      throw Error("--aa", fmt::format("'{}' is not analytic or ssN", a.aa), "write e.g. --aa ss4");
    }
  } else {
    throw Error("--aa", fmt::format("'{}' is not analytic or ssN", a.aa), "write e.g. --aa analytic");
  }
  m.warp_scale = a.warp_scale;
  if (a.warp_filter != "cubic" && a.warp_filter != "bilinear") {
    throw Error("--warp-filter", fmt::format("'{}' is not bilinear or cubic", a.warp_filter), "choose one");
  }
  m.warp_filter = a.warp_filter == "cubic" ? WarpFilter::kCubic : WarpFilter::kBilinear;
  std::tie(m.warp_grid_cols, m.warp_grid_rows) = ParseCount2(a.warp_grid, "--warp-grid");
  if (a.mesh_subdivision == "uniform") {
    m.mesh_subdivision = MeshSubdivision::kUniform;
  } else if (a.mesh_subdivision == "perez") {
    m.mesh_subdivision = MeshSubdivision::kPerez;
  } else if (a.mesh_subdivision == "extended") {
    m.mesh_subdivision = MeshSubdivision::kExtended;
  } else {
    throw Error("--mesh-subdivision", fmt::format("'{}' is unknown", a.mesh_subdivision),
                "use uniform, perez or extended");
  }
  m.mesh_patch_px = a.mesh_patch_px;
  m.mesh_level = a.mesh_level;
  m.mesh_tolerance_px = a.mesh_tolerance_px;
  m.strips = a.strips;
  o.display_gamma = a.gamma;
  o.surround_code = a.surround;
  o.Check("method options");
  return o;
}

}  // namespace curvecheck
