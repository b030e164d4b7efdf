// `curvecheck plan --monitor M (--camera cam.cameramodel | --sensor-px W,H --focal-px F) [--pattern
// pattern.json]
// [--target-sigma-mm S] [--tolerance T] [--photos N] -o DIR`: the capture plan (analysis/plan.h). Prints the
// table, writes DIR/plan.json (curvecheck.plan/1) and DIR/plan.png (+ plan.gp, plan.dat: the chart and what
// draws it). The work is analysis/plan_run.h; this file parses the options.
#include "app/plan_command.h"

#include <iostream>
#include <memory>

#include "analysis/plan_run.h"
#include "app/cli.h"

namespace curvecheck::app {

void AddPlanCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<PlanRequest>();
  CLI::App* cmd = app.add_subcommand(
      "plan",
      "Plan the capture: predict the radius sigma and the verification's uncertainty a camera reaches on a "
      "monitor, "
      "and recommend camera positions and a number of photos (writes plan.json and a chart)");
  cmd->add_option("--monitor,-m", args->monitor, "Monitor preset name, 'default', or a YAML/JSON spec file")
      ->capture_default_str();
  cmd->add_option("--camera,-c", args->camera,
                  "The camera's model (.cameramodel; its .intrinsics_covariance.json "
                  "beside it, if any, gives the lens calibration row)");
  cmd->add_option("--sensor-px", args->sensor_px, "Or a pinhole camera: imager W,H in px (with --focal-px)");
  cmd->add_option("--focal-px", args->focal_px, "The pinhole camera's focal length in px (with --sensor-px)");
  cmd->add_option(
      "--pattern,-p", args->pattern,
      "pattern.json of the rendering to photograph (default: render's default checkerboard for the eye "
      "1.5 m in front of the screen centre)");
  cmd->add_option(
      "--target-sigma-mm", args->options.target_radius_sigma_mm,
      "Radius sigma to reach, mm (the fewest photos that reach it are planned; default: none, 4 photos)");
  cmd->add_option("--tolerance", args->options.tolerance_display_px,
                  "Verification tolerance T, display px (as analyze's --tolerance)")
      ->capture_default_str();
  cmd->add_option("--photos", args->options.photos,
                  "A fixed number of photos (default: the fewest that reach the "
                  "target)");
  cmd->add_option("--max-photos", args->options.max_photos, "The most photos to plan")->capture_default_str();
  cmd->add_option(
      "--distances-mm", args->distances_mm,
      "Distances from the screen centre to search, mm (default 700,850,1000,1250,1500,2000,2500,3000)");
  cmd->add_option("--yaws-deg", args->yaws_deg,
                  "Yaws about the screen centre to search, deg, each also mirrored "
                  "(default 0,10,20,30,40,50)");
  cmd->add_option("--heights-mm", args->heights_mm,
                  "Heights above the screen centre to search, mm (default 0,150)");
  cmd->add_option(
      "--lens-covariance", args->lens_covariance,
      "The lens calibration's intrinsics covariance (default: CAM.intrinsics_covariance.json beside "
      "--camera, when it exists)");
  cmd->add_option("--pitch-tolerance", args->pitch_tolerance_percent,
                  "The datasheet pixel pitch's tolerance, percent (as analyze's)")
      ->capture_default_str();
  cmd->add_option("--seeds", args->options.seeds, "Simulated detection draws averaged in the prediction")
      ->capture_default_str();
  cmd->add_option("-o,--output", args->output, "Output folder (plan.json, plan.png)")->required();
  cmd->callback([&run, args] {
    run = [args] {
      PlanToFolder(*args, CommandLine(), std::cout);
      return 0;
    };
  });
}

}  // namespace curvecheck::app
