// `curvecheck plan --monitor M (--camera cam.cameramodel | --sensor-px W,H --focal-px F) [--pattern
// pattern.json]
// [--target-sigma-mm S] [--tolerance T] [--photos N] -o DIR`: the capture plan (analysis/plan.h). Prints the
// table, writes DIR/plan.json (curvecheck.plan/1) and DIR/plan.png (+ plan.gp, plan.dat: the chart and what
// draws it).
#include "app/plan_command.h"

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "analysis/plan.h"
#include "app/cli.h"
#include "app/output_paths.h"
#include "core/decimal.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"
#include "pattern/pattern.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct PlanArgs {
  std::string monitor = "default";
  std::string camera;
  std::string sensor_px;
  std::optional<double> focal_px;
  std::string pattern;
  std::string output;
  std::string lens_covariance;
  std::string distances_mm, yaws_deg, heights_mm;
  double pitch_tolerance_percent = 0.1;
  PlanOptions options;
};

std::vector<double> Numbers(const std::string& text, const std::string& option) {
  std::vector<double> out;
  for (const std::string& part : SplitList(text, ',')) {
    const std::optional<double> v = ParseDecimal(part);
    if (!v)
      throw Error(option, fmt::format("'{}' is not a number", part),
                  "give a comma-separated list, e.g. 1000,1500");
    out.push_back(*v);
  }
  if (out.empty()) throw Error(option, "is empty", "give a comma-separated list, e.g. 1000,1500");
  return out;
}

CameraModel ResolveCamera(const PlanArgs& a) {
  const bool synthetic = !a.sensor_px.empty() || a.focal_px;
  if (a.camera.empty() == !synthetic) {
    throw Error("plan", "give either --camera or both --sensor-px and --focal-px",
                "e.g. --camera cam.cameramodel, or --sensor-px 6000,4000 --focal-px 8900");
  }
  if (!a.camera.empty()) return ReadCameraModel(a.camera);
  if (a.sensor_px.empty() || !a.focal_px)
    throw Error("plan", "--sensor-px and --focal-px go together", "give both");
  const std::vector<double> wh = Numbers(a.sensor_px, "--sensor-px");
  if (wh.size() != 2 || !(wh[0] >= 64 && wh[1] >= 64 && wh[0] <= 100000 && wh[1] <= 100000) ||
      wh[0] != std::floor(wh[0]) || wh[1] != std::floor(wh[1])) {
    throw Error("--sensor-px", fmt::format("'{}' is not an imager size", a.sensor_px),
                "give W,H in px, e.g. 6000,4000");
  }
  if (!(*a.focal_px > 0 && *a.focal_px < 1e6)) {
    throw Error("--focal-px", fmt::format("{} is not a focal length in px", *a.focal_px), "give e.g. 8900");
  }
  return PinholeModel(static_cast<int>(wh[0]), static_cast<int>(wh[1]), *a.focal_px);
}

int RunPlan(PlanArgs a) {
  const Monitor monitor = LoadMonitor(a.monitor);
  const CameraModel camera = ResolveCamera(a);
  if (!a.distances_mm.empty()) a.options.distances_mm = Numbers(a.distances_mm, "--distances-mm");
  if (!a.yaws_deg.empty()) a.options.yaws_deg = Numbers(a.yaws_deg, "--yaws-deg");
  if (!a.heights_mm.empty()) a.options.heights_mm = Numbers(a.heights_mm, "--heights-mm");
  a.options.fit.pitch_tolerance_relative = a.pitch_tolerance_percent / 100;
  // The lens calibration's covariance, as analyze finds it: given, or beside the camera model.
  const fs::path beside = a.camera.empty() ? fs::path() : IntrinsicsCovariancePathFor(a.camera);
  const fs::path cov_path = !a.lens_covariance.empty() ? fs::path(a.lens_covariance) : beside;
  std::vector<fs::path> inputs;
  if (!a.camera.empty()) inputs.push_back(a.camera);
  if (!a.lens_covariance.empty() || (!beside.empty() && fs::exists(beside))) {
    const IntrinsicsCovariance cov = ReadIntrinsicsCovariance(cov_path, camera);
    a.options.fit.intrinsics_covariance = cov.covariance;
    a.options.fit.intrinsics_covariance_dof = cov.dof;
    a.options.fit.intrinsics_covariance_source = cov.source;
    inputs.push_back(cov_path);
  }
  // The pattern: the one given, or render's default (its checkerboard for the eye 1.5 m in front of the
  // centre).
  PatternFile pattern;
  if (!a.pattern.empty()) {
    pattern = ReadPatternJson(a.pattern);
    inputs.push_back(a.pattern);
  } else {
    const Eigen::Vector3d eye = ScreenCentreInScreen(monitor) + Eigen::Vector3d(0, 0, 1500);
    const Pattern p = BuildPattern(PatternSpec{}, monitor, eye, TangentPlaneAtCentre(monitor));
    pattern = ParsePatternJson(PatternToJson(p, monitor, eye, {{"name", "exact"}}).dump(),
                               "render's default pattern");
  }
  a.options.Check("plan options");

  const fs::path dir = a.output;
  const std::vector<NamedOutput> outputs = {{"plan.json", dir / "plan.json"},
                                            {"plan.png", dir / "plan.png"},
                                            {"plan.gp", dir / "plan.gp"},
                                            {"plan.dat", dir / "plan.dat"}};
  CheckOutputs(outputs, inputs);
  OutputFolder folder(dir, "-o");
  const CapturePlan plan = PlanCapture(monitor, camera, pattern, a.options);
  std::cout << PlanText(plan, a.options);
  // The chart is drawn before anything is published: plan.json, the chart, its script and data go together.
  const std::string data = PlanChartData(plan);
  std::string png;
  {
    const ChartDataFolder tmp("the plan chart");
    WriteFileAtomic(tmp.path() / "plan.dat", data);
    png = RenderGnuplot(PlanChartScript(plan, (tmp.path() / "plan.dat").string()), ChartFormat::kPng,
                        {1400, 600});
  }
  OutputSet set;
  set.Write(dir / "plan.json", PlanJson(plan, monitor, camera, a.options, CommandLine()).dump(1) + "\n");
  set.Write(dir / "plan.dat", data);
  set.Write(dir / "plan.png", png);
  set.Write(dir / "plan.gp", "set terminal pngcairo size 1400,600\nset output \"plan.png\"\n" +
                                 PlanChartScript(plan, "plan.dat"));
  set.Publish();
  folder.Keep();
  std::cout << fmt::format("\nwrote {} and the chart {} (gnuplot plan.gp in {} redraws it from plan.dat)\n",
                           (dir / "plan.json").string(), (dir / "plan.png").string(), dir.string());
  return 0;
}

}  // namespace

void AddPlanCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<PlanArgs>();
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
  cmd->callback([&run, args] { run = [args] { return RunPlan(*args); }; });
}

}  // namespace curvecheck::app
