// `curvecheck render`: render a corrected pattern and write PATTERN.png + PATTERN.json (ground truth)
// (render/pattern_files.h), then present it with --present.
#include "app/render_command.h"

#include <iostream>
#include <memory>
#include <optional>

#include "app/present_command.h"
#include "app/render_options.h"
#include "render/pattern_files.h"

namespace curvecheck::app {
namespace {

struct RenderArgs {
  RenderFilesRequest files;
  bool present = false;  // then show the PNG fullscreen on output `display` (app/present_command.h)
  int display = 0;
  std::optional<int> hold_ms;
};

int RunRender(const RenderArgs& a) {
  RenderPatternFiles(a.files, std::cout);
  if (a.present) {
    PresenterOptions present;
    present.display = a.display;
    present.images = {a.files.output};
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
  AddSceneOptions(*cmd, args->files.scene, "1.5 m in front of the screen centre");
  AddMethodOptions(*cmd, args->files.method);
  cmd->add_option("-o,--output", args->files.output, "Output PNG (the JSON is written beside it)")->required();
  cmd->add_flag("--accuracy", args->files.accuracy,
                "Also render the method's plane coordinates and report its mapping error against the exact mapping");
  cmd->add_option("--error-map", args->files.error_map, "Write the mapping error map (PNG heatmap); implies --accuracy");
  cmd->add_flag("--present", args->present,
                "Then show the PNG fullscreen, pixel for pixel, on output --display (see `curvecheck present`)");
  cmd->add_option("--display", args->display, "Output for --present (0 = primary)")->capture_default_str();
  cmd->add_option("--hold-ms", args->hold_ms, "With --present: show for this long, then exit");
  cmd->callback([&run, args] { run = [args] { return RunRender(*args); }; });
}

}  // namespace curvecheck::app
