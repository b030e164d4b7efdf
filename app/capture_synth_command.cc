// `curvecheck capture synth --scene SCENE.yaml --display pattern.png -o photo.png`: the synthetic camera.
// Writes photo.png and photo.truth.json (the true image position of every feature of pattern.json, which must
// sit beside the display image). The work is synth/photo_run.h; this file parses the options.
#include "app/capture_synth_command.h"

#include <iostream>
#include <memory>

#include "synth/photo_run.h"

namespace curvecheck::app {

void AddCaptureSynthCommand(CLI::App& capture, std::function<int()>& run) {
  auto args = std::make_shared<SynthPhotoRequest>();
  CLI::App* cmd = capture.add_subcommand(
      "synth", "Ray-trace a photo of the scene's true monitor showing a pattern; writes PHOTO.png, "
               "PHOTO.truth.json (true image position of every feature of the pattern's pattern.json) and "
               "PHOTO.cameramodel (the photo's camera in mrcal format, at --scale: give it to analyze --camera)");
  cmd->add_option("--scene", args->scene, "Scene YAML (datasets/scenes/)")->required();
  cmd->add_option("--display", args->display, "The pattern PNG shown on the display (its .json beside it)")
      ->required();
  cmd->add_option("-o,--output", args->output,
                  "Output photo: PNG (gray or colour), or .jpg for the realistic chain's JPEG itself")
      ->required();
  cmd->add_option("--ray-grid-px", args->ray_grid_px, "Spacing of the unprojection grid, px")->capture_default_str();
  cmd->add_option("--set", args->overrides,
                  "Override a scene field, KEY=VALUE with a dotted key (repeatable), e.g. --set optics.blur=none "
                  "--set sensor.noise=false --set true_monitor.lean_deg=0.5");
  cmd->add_option("--scale", args->scale,
                  "Shrink the camera's imager by this factor (0..1], lens scaled with it: quick previews and tests "
                  "(PHOTO.cameramodel is the scaled camera)");
  cmd->callback([&run, args] {
    run = [args] {
      TakeSyntheticPhoto(*args, std::cout);
      return 0;
    };
  });
}

}  // namespace curvecheck::app
