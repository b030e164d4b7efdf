// `curvecheck render`: render a corrected pattern and write PATTERN.png + PATTERN.json (ground truth).
#include "app/render_command.h"

#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "app/present_command.h"
#include "app/output_paths.h"
#include "app/render_options.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "render/mapping_error.h"
#include "pattern/pattern_json.h"
#include "render/renderer.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct RenderArgs {
  SceneArgs scene;
  MethodArgs method;
  std::string output;
  std::optional<std::string> error_map;
  bool accuracy = false;
  bool present = false;  // then show the PNG fullscreen on output `display` (app/present_command.h)
  int display = 0;
  std::optional<int> hold_ms;
};

// Refuses to write over a file the command reads.
std::vector<fs::path> Inputs(const RenderArgs& a) {
  std::vector<fs::path> inputs = {a.scene.monitor};
  if (a.scene.pattern_file) inputs.push_back(*a.scene.pattern_file);
  return inputs;
}

int RunRender(const RenderArgs& a) {
  const fs::path png = a.output;
  if (png.extension() != ".png") throw Error("-o", fmt::format("'{}' does not end in .png", a.output), "write e.g. -o out.png");
  const fs::path json = fs::path(png).replace_extension(".json");
  // Outputs against the inputs and one another (`--error-map x.png -o x.png`, or `--error-map x.json` beside
  // x.png's pattern.json, would lose one of them), and writable, before the render.
  std::vector<NamedOutput> outputs = {{"-o", png}, {"the pattern.json beside -o", json}};
  if (a.error_map) outputs.push_back({"--error-map", *a.error_map});
  CheckOutputs(outputs, Inputs(a));
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
    std::cout << fmt::format("mapping error vs exact: rms {:.4f} px, p99 {:.4f} px, max {:.4f} px over {} px{}\n",
                             err.rms_px, err.p99_px, err.max_px, err.pixels,
                             err.missing_pixels ? fmt::format(" ({} px not drawn)", err.missing_pixels) : "");
    if (a.error_map) {
      const double scale = std::max(1e-3, err.max_finite_px);
      set.WriteWith(*a.error_map, [&](const fs::path& staged) {
        WriteHeatmapPng(staged, scene.monitor.width_px, scene.monitor.height_px, err.map_px, scale);
      });
      std::cout << fmt::format("error map (0 .. {:.3g} px, viridis; pixels not drawn in magenta) -> {}\n", scale,
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
  std::cout << fmt::format("{}: {} on {} ({} x {} px), {} features ({} visible); rendered in {:.1f} ms on {} "
                           "(set-up {:.1f} ms)\n{}\nwrote {} and {}\n",
                           options.method.Label(), PatternKindName(pattern.spec.kind), scene.monitor.name,
                           image.width, image.height, pattern.features.size(), visible, timing.render_ms,
                           renderer.device_name(), renderer.setup_ms(),
                           DescribeViewpoint(scene.monitor, scene.viewpoint_in_screen), png.string(), json.string());
  if (a.present) {
    PresenterOptions present;
    present.display = a.display;
    present.images = {png};
    present.hold_ms = a.hold_ms;
    return RunPresent(present);
  }
  return 0;
}

}  // namespace

void AddRenderCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render a corrected checkerboard/AprilTag pattern: writes OUT.png and OUT.json (pattern.json ground "
                "truth: every feature's 3D point and exact display position)");
  AddSceneOptions(*cmd, args->scene, "1.5 m in front of the screen centre");
  AddMethodOptions(*cmd, args->method);
  cmd->add_option("-o,--output", args->output, "Output PNG (the JSON is written beside it)")->required();
  cmd->add_flag("--accuracy", args->accuracy,
                "Also render the method's plane coordinates and report its mapping error against the exact mapping");
  cmd->add_option("--error-map", args->error_map, "Write the mapping error map (PNG heatmap); implies --accuracy");
  cmd->add_flag("--present", args->present,
                "Then show the PNG fullscreen, pixel for pixel, on output --display (see `curvecheck present`)");
  cmd->add_option("--display", args->display, "Output for --present (0 = primary)")->capture_default_str();
  cmd->add_option("--hold-ms", args->hold_ms, "With --present: show for this long, then exit");
  cmd->callback([&run, args] { run = [args] { return RunRender(*args); }; });
}

}  // namespace curvecheck::app
