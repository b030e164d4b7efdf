// `curvecheck render` and `curvecheck pattern` once their options are parsed (pattern_files.h).
#include "render/pattern_files.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <ostream>
#include <vector>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/output_paths.h"
#include "core/viewing.h"
#include "pattern/pattern_json.h"
#include "render/mapping_error.h"
#include "render/pattern_texture.h"
#include "render/renderer.h"

namespace curvecheck {
namespace fs = std::filesystem;
namespace {

// Refuses to write over a file the command reads.
std::vector<fs::path> Inputs(const SceneArgs& a) {
  std::vector<fs::path> inputs = {a.monitor};
  if (a.pattern_file) inputs.push_back(*a.pattern_file);
  return inputs;
}

}  // namespace

void RenderPatternFiles(const RenderFilesRequest& a, std::ostream& log) {
  const fs::path png = a.output;
  if (png.extension() != ".png") throw Error("-o", fmt::format("'{}' does not end in .png", a.output), "write e.g. -o out.png");
  const fs::path json = fs::path(png).replace_extension(".json");
  // Outputs against the inputs and one another (`--error-map x.png -o x.png`, or `--error-map x.json` beside
  // x.png's pattern.json, would lose one of them), and writable, before the render.
  std::vector<NamedOutput> outputs = {{"-o", png}, {"the pattern.json beside -o", json}};
  if (a.error_map) outputs.push_back({"--error-map", *a.error_map});
  CheckOutputs(outputs, Inputs(a.scene));
  for (const NamedOutput& o : outputs) CheckWritable(o.path);
  const Scene scene = ResolveScene(a.scene, Eigen::Vector3d(0, 0, 1500));
  const RenderOptions options = ResolveMethod(a.method);
  const Pattern pattern = BuildPattern(scene.spec, scene.monitor, scene.viewpoint_in_screen,
                                       TangentPlaneAtCentre(scene.monitor));
  Renderer renderer;
  RenderTiming timing;
  const GrayImage image = renderer.Render(scene.monitor, scene.viewpoint_in_screen, pattern, options, &timing);

  nlohmann::json doc = PatternToJson(pattern, scene.monitor, scene.viewpoint_in_screen, options.method.ToJson());
  doc["render"] = {{"device", renderer.device_name()},
                   {"display_gamma", options.display_gamma},
                   {"surround_code", options.surround_code},
                   {"render_ms", timing.render_ms},
                   {"setup_ms", renderer.setup_ms()},
                   {"image", png.filename().string()},
                   // what capture synth and capture sessions check that a display PNG is this one
                   {"image_content_hash", DisplayImageHash({image.width, image.height, 1, image.pixels})},
                   {"command", "curvecheck render"}};
  OutputSet set;  // the PNG, its pattern.json and the error map: all new or all old
  if (a.accuracy || a.error_map) {
    const CoordinateImage coords =
        renderer.RenderCoordinates(scene.monitor, scene.viewpoint_in_screen, pattern, options);
    const MappingError err = MeasureMappingError(scene.monitor, scene.viewpoint_in_screen, pattern, coords);
    doc["mapping_error_px"] = {{"rms", err.rms_px}, {"p99", err.p99_px}, {"max", err.max_px},
                               {"pixels", err.pixels}, {"missing_pixels", err.missing_pixels}};
    log << fmt::format("mapping error vs exact: rms {:.4f} px, p99 {:.4f} px, max {:.4f} px over {} px{}\n",
                             err.rms_px, err.p99_px, err.max_px, err.pixels,
                             err.missing_pixels ? fmt::format(" ({} px not drawn)", err.missing_pixels) : "");
    if (a.error_map) {
      const double scale = std::max(1e-3, err.max_finite_px);
      set.WriteWith(*a.error_map, [&](const fs::path& staged) {
        WriteHeatmapPng(staged, scene.monitor.width_px, scene.monitor.height_px, err.map_px, scale);
      });
      log << fmt::format("error map (0 .. {:.3g} px, viridis; pixels not drawn in magenta) -> {}\n", scale,
                               *a.error_map);
    }
  }
  set.WriteWith(png, [&](const fs::path& staged) {
    WritePng8(staged, image.width, image.height, 1, image.pixels.data());
  });
  set.Write(json, doc.dump(1) + "\n");
  set.Publish();
  int visible = 0;
  for (const Feature& f : pattern.features) visible += f.visible ? 1 : 0;
  log << fmt::format("{}: {} on {} ({} x {} px), {} features ({} visible); rendered in {:.1f} ms on {} "
                           "(set-up {:.1f} ms)\n{}\nwrote {} and {}\n",
                           options.method.Label(), PatternKindName(pattern.spec.kind), scene.monitor.name,
                           image.width, image.height, pattern.features.size(), visible, timing.render_ms,
                           renderer.device_name(), renderer.setup_ms(),
                           DescribeViewpoint(scene.monitor, scene.viewpoint_in_screen), png.string(), json.string());
}

void ExportPatternFiles(const PatternExportRequest& a, std::ostream& log) {
  const fs::path dir = a.output;
  const fs::path texture = dir / "texture.png", plane = dir / "plane.json", json = dir / "pattern.json";
  CheckOutputs({{"-o DIR/texture.png", texture}, {"-o DIR/plane.json", plane}, {"-o DIR/pattern.json", json}}, Inputs(a.scene));
  const Scene scene = ResolveScene(a.scene, Eigen::Vector3d(0, 0, 1500));
  const RenderOptions options = ResolveMethod(a.method);
  const Pattern pattern = BuildPattern(scene.spec, scene.monitor, scene.viewpoint_in_screen,
                                       TangentPlaneAtCentre(scene.monitor));
  const PatternQuad quad = MakePatternQuad(scene.monitor, scene.viewpoint_in_screen);
  OutputFolder folder(dir, "-o");
  Renderer renderer;
  const GrayImage image = RenderPatternTexture(renderer, quad, scene.viewpoint_in_screen, pattern, options);

  // pattern.json as `render` writes it, without its "render" object (no display image goes with it): the exact
  // display positions for this monitor and viewpoint.
  nlohmann::json doc = PatternToJson(pattern, scene.monitor, scene.viewpoint_in_screen, options.method.ToJson());
  doc["pattern_export"] = {{"texture", texture.filename().string()},
                           {"plane", plane.filename().string()},
                           {"display_gamma", options.display_gamma},
                           {"command", "curvecheck pattern"}};
  OutputSet set;
  set.WriteWith(texture, [&](const fs::path& staged) {
    WritePng8(staged, image.width, image.height, 1, image.pixels.data());
  });
  set.Write(plane, PlaneToJson(quad, scene.monitor, scene.viewpoint_in_screen, options, "texture.png").dump(1) + "\n");
  set.Write(json, doc.dump(1) + "\n");
  set.Publish();
  folder.Keep();
  int visible = 0;
  for (const Feature& f : pattern.features) visible += f.visible ? 1 : 0;
  log << fmt::format(
      "{} on {}: texture {} x {} px on the chord-plane quad {:.1f} x {:.1f} mm at z = {:.1f} mm (screen frame), "
      "{} features ({} visible)\n{}\nwrote {}, {} and {}\n",
      PatternKindName(pattern.spec.kind), scene.monitor.name, image.width, image.height, quad.width_mm, quad.height_mm,
      quad.top_left_in_screen.z(), pattern.features.size(), visible,
      DescribeViewpoint(scene.monitor, scene.viewpoint_in_screen), texture.string(), plane.string(), json.string());
}

}  // namespace curvecheck
