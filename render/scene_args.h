// What `render`, `pattern` and `bench render` draw, as their options give it (app/render_options.h registers the
// options): the monitor, viewpoint and pattern (SceneArgs -> Scene) and the correction method (MethodArgs ->
// RenderOptions), resolved and checked with errors naming the option at fault.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>

#include "core/monitor.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {

struct SceneArgs {
  std::string monitor = "default";
  std::string viewpoint;  // "x,y,z"; empty = the command's default
  // --distance-mm D [--offset-mm X,Y]: the viewpoint from the screen centre (ViewpointFromScreenCentre).
  std::optional<double> distance_mm;
  std::optional<std::string> offset_mm;
  std::string pattern = "checkerboard";
  std::optional<std::string> pattern_file;
  std::optional<std::string> squares, tags;  // "CxR"
  std::optional<double> square_mm, tag_mm, margin;
  std::optional<int> first_tag_id, tag_gap_cells;
};

struct MethodArgs {
  std::string method = "exact";
  std::string aa = "analytic";  // analytic | ssN
  double warp_scale = 1.0;
  std::string warp_filter = "cubic";
  std::string warp_grid = "0x0";  // CxR cells, 0x0 = per fragment
  std::string mesh_subdivision = "extended";
  double mesh_patch_px = 256;
  int mesh_level = 16;
  double mesh_tolerance_px = 0.05;
  int strips = 32;
  double gamma = 2.2;
  int surround = 128;
};

struct Scene {
  Monitor monitor;
  Eigen::Vector3d viewpoint_in_screen;
  PatternSpec spec;
};
// Validates and resolves the scene; default_viewpoint_from_centre is used when --viewpoint is empty (an
// offset from the screen centre, e.g. 0,0,1500). Throws Error naming the option at fault.
Scene ResolveScene(const SceneArgs& args, const Eigen::Vector3d& default_viewpoint_from_centre);
RenderOptions ResolveMethod(const MethodArgs& args);
// "16x5" -> {16, 5}; throws Error naming the option.
std::pair<int, int> ParseCount2(const std::string& text, const std::string& option);

}  // namespace curvecheck
