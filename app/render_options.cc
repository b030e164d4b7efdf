#include "app/render_options.h"

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

}  // namespace curvecheck::app
