#include "app/render_options.h"

#include <fmt/format.h>

#include <cmath>

#include "core/config.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"

namespace curvecheck::app {

void AddSceneOptions(CLI::App& cmd, SceneArgs& a, const std::string& default_viewpoint_help) {
  cmd.add_option("--monitor,-m", a.monitor, "Monitor preset name, 'default', or a YAML/JSON spec file")
      ->capture_default_str();
  CLI::Option* viewpoint = cmd.add_option(
      "--viewpoint,-v", a.viewpoint,
      "Viewpoint x,y,z in mm, screen frame (origin on the cylinder axis, screen centre at 0,0,-R; flat: screen is "
      "z = 0; or give --distance-mm). Default: " + default_viewpoint_help);
  AddDistanceOptions(cmd, viewpoint, a.distance_mm, a.offset_mm);
  cmd.add_option("--pattern,-p", a.pattern, "checkerboard | apriltag | both (tags in the white squares)")
      ->capture_default_str();
  cmd.add_option("--pattern-file", a.pattern_file, "Pattern spec YAML (keys as pattern/pattern.h PatternSpec)");
  cmd.add_option("--squares", a.squares, "Checkerboard squares across x down, e.g. 16x5");
  cmd.add_option("--square-mm", a.square_mm, "Square size on the pattern plane, mm (default: fit the screen)");
  cmd.add_option("--tags", a.tags, "AprilTag grid across x down, e.g. 12x3");
  cmd.add_option("--tag-mm", a.tag_mm, "Tag size (black border) in mm (default: fit the screen)");
  cmd.add_option("--first-tag-id", a.first_tag_id, "First tag36h11 id");
  cmd.add_option("--tag-gap-cells", a.tag_gap_cells, "Gap between tags in cells of tag size / 8 (>= 2)");
  cmd.add_option("--margin", a.margin, "Free margin around a fitted pattern, fraction of the display per side");
}

void AddDistanceOptions(CLI::App& cmd, CLI::Option* viewpoint, std::optional<double>& distance_mm,
                        std::optional<std::string>& offset_mm) {
  CLI::Option* distance = cmd.add_option(
      "--distance-mm", distance_mm,
      "Viewpoint this far (mm) in front of the screen centre, along the screen's normal there (instead of "
      "--viewpoint, which is measured from the cylinder axis)");
  distance->excludes(viewpoint);
  cmd.add_option("--offset-mm", offset_mm,
                 "With --distance-mm: move the viewpoint X,Y mm right and up, parallel to the screen at its centre")
      ->needs(distance);
}

std::optional<Eigen::Vector3d> ViewpointFromOptions(const Monitor& monitor, const std::string& viewpoint,
                                                    const std::optional<double>& distance_mm,
                                                    const std::optional<std::string>& offset_mm) {
  std::optional<Eigen::Vector3d> v;
  std::string option = "--viewpoint";
  if (distance_mm) {
    option = "--distance-mm";
    if (!std::isfinite(*distance_mm) || *distance_mm <= 0) {
      throw Error("--distance-mm", fmt::format("{} is not a positive distance", *distance_mm),
                  "give the distance from the screen centre in mm, e.g. --distance-mm 600");
    }
    Eigen::Vector2d offset = Eigen::Vector2d::Zero();
    if (offset_mm) {
      const std::vector<double> o = ParseNumberList(*offset_mm, 2, "--offset-mm");
      offset = Eigen::Vector2d(o[0], o[1]);
    }
    v = ViewpointFromScreenCentre(monitor, *distance_mm, offset);
  } else if (!viewpoint.empty()) {
    const std::vector<double> p = ParseNumberList(viewpoint, 3, "--viewpoint");
    v = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  if (v) CheckViewpoint(monitor, *v, option);
  return v;
}

std::string DescribeViewpoint(const Monitor& monitor, const Eigen::Vector3d& v) {
  return fmt::format("viewpoint ({:g}, {:g}, {:g}) mm (screen frame), {:.1f} mm from the screen centre", v.x(), v.y(),
                     v.z(), (v - ScreenCentreInScreen(monitor)).norm());
}

void AddMethodOptions(CLI::App& cmd, MethodArgs& a) {
  cmd.add_option("--method", a.method, "exact | warp | mesh | strips | none")->capture_default_str();
  cmd.add_option("--aa", a.aa, "exact: analytic | ssN (N x N rays per pixel)")->capture_default_str();
  cmd.add_option("--warp-scale", a.warp_scale, "warp: first-pass size / display size")->capture_default_str();
  cmd.add_option("--warp-filter", a.warp_filter, "warp: bilinear | cubic")->capture_default_str();
  cmd.add_option("--warp-grid", a.warp_grid, "warp: distortion grid cells CxR; 0x0 = per fragment")
      ->capture_default_str();
  cmd.add_option("--mesh-subdivision", a.mesh_subdivision, "mesh: uniform | perez | extended")->capture_default_str();
  cmd.add_option("--mesh-patch-px", a.mesh_patch_px, "mesh: base patch edge in display px")->capture_default_str();
  cmd.add_option("--mesh-level", a.mesh_level, "mesh uniform: segments per patch edge (1..64)")
      ->capture_default_str();
  cmd.add_option("--mesh-tolerance-px", a.mesh_tolerance_px, "mesh perez/extended: edge tolerance, px")
      ->capture_default_str();
  cmd.add_option("--strips", a.strips, "strips: number of vertical slices")->capture_default_str();
  cmd.add_option("--gamma", a.gamma, "display gamma used for anti-aliasing in linear light")->capture_default_str();
  cmd.add_option("--surround", a.surround, "grey code value around the pattern")->capture_default_str();
}

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

}  // namespace curvecheck::app
