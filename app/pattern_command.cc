// `curvecheck pattern`: DIR/texture.png, DIR/plane.json, DIR/pattern.json for drawing the pattern in another
// application's scene (render/pattern_texture.h).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "app/output_paths.h"
#include "app/render_options.h"
#include "app/thirdparty_commands.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "pattern/pattern_json.h"
#include "render/pattern_texture.h"
#include "render/renderer.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct PatternArgs {
  SceneArgs scene;
  MethodArgs method;  // only --aa, --gamma, --surround: the texture is drawn by the exact method
  std::string output = "pattern";
};

int RunPattern(const PatternArgs& a) {
  const fs::path dir = a.output;
  const fs::path texture = dir / "texture.png", plane = dir / "plane.json", json = dir / "pattern.json";
  std::vector<fs::path> inputs = {a.scene.monitor};
  if (a.scene.pattern_file) inputs.push_back(*a.scene.pattern_file);
  CheckOutputs({{"-o DIR/texture.png", texture}, {"-o DIR/plane.json", plane}, {"-o DIR/pattern.json", json}}, inputs);
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
  std::cout << fmt::format(
      "{} on {}: texture {} x {} px on the chord-plane quad {:.1f} x {:.1f} mm at z = {:.1f} mm (screen frame), "
      "{} features ({} visible)\n{}\nwrote {}, {} and {}\n",
      PatternKindName(pattern.spec.kind), scene.monitor.name, image.width, image.height, quad.width_mm, quad.height_mm,
      quad.top_left_in_screen.z(), pattern.features.size(), visible,
      DescribeViewpoint(scene.monitor, scene.viewpoint_in_screen), texture.string(), plane.string(), json.string());
  return 0;
}

}  // namespace

void AddPatternCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<PatternArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pattern", "Write the pattern for another application's own correction: DIR/texture.png (the flat pattern "
                 "image on the chord-plane quad), DIR/plane.json (the quad's corners, the eye, texture conventions) "
                 "and DIR/pattern.json (every feature's exact display position)");
  AddSceneOptions(*cmd, args->scene, "1.5 m in front of the screen centre");
  cmd->add_option("--aa", args->method.aa, "analytic | ssN (N x N rays per texel)")->capture_default_str();
  cmd->add_option("--gamma", args->method.gamma, "display gamma of the anti-aliasing (code = linear^(1/gamma))")
      ->capture_default_str();
  cmd->add_option("--surround", args->method.surround, "grey code value around the pattern")->capture_default_str();
  cmd->add_option("-o,--output", args->output, "Output folder")->capture_default_str();
  cmd->callback([&run, args] { run = [args] { return RunPattern(*args); }; });
}

}  // namespace curvecheck::app
