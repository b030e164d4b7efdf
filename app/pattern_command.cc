// `curvecheck pattern`: DIR/texture.png, DIR/plane.json, DIR/pattern.json for drawing the pattern in another
// application's scene (render/pattern_texture.h; the work is render/pattern_files.h).
#include <iostream>
#include <memory>

#include "app/render_options.h"
#include "app/thirdparty_commands.h"
#include "render/pattern_files.h"

namespace curvecheck::app {

void AddPatternCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<PatternExportRequest>();
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
  cmd->callback([&run, args] {
    run = [args] {
      ExportPatternFiles(*args, std::cout);
      return 0;
    };
  });
}

}  // namespace curvecheck::app
