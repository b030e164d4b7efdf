// `curvecheck plan` once its options are parsed (plan_run.h).
#include "analysis/plan_run.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <ostream>

#include "core/config.h"
#include "core/decimal.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/output_paths.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"
#include "pattern/pattern.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;

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

CameraModel ResolveCamera(const PlanRequest& a) {
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

}  // namespace

void PlanToFolder(PlanRequest a, const std::string& command_line, std::ostream& log) {
  const Monitor monitor = LoadMonitor(a.monitor);
  const CameraModel camera = ResolveCamera(a);
  if (!a.distances_mm.empty()) a.options.distances_mm = Numbers(a.distances_mm, "--distances-mm");
  if (!a.yaws_deg.empty()) a.options.yaws_deg = Numbers(a.yaws_deg, "--yaws-deg");
  if (!a.heights_mm.empty()) a.options.heights_mm = Numbers(a.heights_mm, "--heights-mm");
  a.options.fit.pitch_tolerance_relative = PitchToleranceFromPercent(a.pitch_tolerance_percent, "--pitch-tolerance");
  // The lens calibration's covariance, as analyze finds it: given, or beside the camera model.
  const fs::path beside = a.camera.empty() ? fs::path() : IntrinsicsCovariancePathFor(a.camera);
  const fs::path cov_path = !a.lens_covariance.empty() ? fs::path(a.lens_covariance) : beside;
  std::vector<fs::path> inputs;
  if (!a.camera.empty()) inputs.push_back(a.camera);
  if (!a.lens_covariance.empty() || (!beside.empty() && fs::exists(beside))) {
    ReadIntrinsicsCovariance(cov_path, camera).ApplyTo(&a.options.fit);
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
  log << PlanText(plan, a.options);
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
  set.Write(dir / "plan.json", PlanJson(plan, monitor, camera, a.options, command_line).dump(1) + "\n");
  set.Write(dir / "plan.dat", data);
  set.Write(dir / "plan.png", png);
  set.Write(dir / "plan.gp", "set terminal pngcairo size 1400,600\nset output \"plan.png\"\n" +
                                 PlanChartScript(plan, "plan.dat"));
  set.Publish();
  folder.Keep();
  log << fmt::format("\nwrote {} and the chart {} (gnuplot plan.gp in {} redraws it from plan.dat)\n",
                           (dir / "plan.json").string(), (dir / "plan.png").string(), dir.string());
}

}  // namespace curvecheck
