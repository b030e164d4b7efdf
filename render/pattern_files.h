// What `curvecheck render` and `curvecheck pattern` write once their options are parsed (app/render_command.cc,
// app/pattern_command.cc): every output checked against the inputs and one another before the render, then the
// set written together. Errors name the option at fault.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "render/scene_args.h"

namespace curvecheck {

struct RenderFilesRequest {
  SceneArgs scene;
  MethodArgs method;
  std::string output;                    // PATTERN.png; PATTERN.json (pattern.json) is written beside it
  std::optional<std::string> error_map;  // the mapping error map (PNG heatmap); implies accuracy
  bool accuracy = false;                 // also measure the method's mapping error against the exact mapping
};

// Renders the corrected pattern: PATTERN.png, its pattern.json (ground truth, with the render's record) and the
// error map, all new or all old; the mapping error, the render time and what was written on `log`.
void RenderPatternFiles(const RenderFilesRequest& request, std::ostream& log);

struct PatternExportRequest {
  SceneArgs scene;
  MethodArgs method;  // only aa, gamma and surround: the texture is drawn by the exact method
  std::string output = "pattern";
};

// For another application's own correction (pattern_texture.h): DIR/texture.png (the flat pattern on the
// chord-plane quad), DIR/plane.json (the quad) and DIR/pattern.json (the exact display positions); `log` says so.
void ExportPatternFiles(const PatternExportRequest& request, std::ostream& log);

}  // namespace curvecheck
