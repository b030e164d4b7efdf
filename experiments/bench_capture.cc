#include "experiments/bench_capture.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/stats.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/trial.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {
namespace {

struct Spread {
  double median = 0, min = 0, max = 0;
};
Spread Summarize(const std::vector<double>& v) {
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return {Median(v), *lo, *hi};
}

}  // namespace

void BenchCaptureOptions::Check() const {
  CheckCount(runs, 1, 100, "--runs");
}

void RunBenchCapture(const BenchCaptureOptions& a, std::ostream& log) {
  a.Check();
  // A file, or an embedded scene: the default works from any folder.
  const SyntheticScene scene = FindScene(a.scene, "--scene");
  Image8 display;
  std::string display_source = a.display;
  if (a.display.empty()) {
    Renderer renderer;
    display =
        RenderTrialDisplay(renderer, scene.monitor, scene.screen_from_cam.translation, PatternSpec()).image;
    display_source = fmt::format("default checkerboard rendered (exact) for the camera position on {}",
                                 renderer.device_name());
  } else {
    display = ReadImage8(a.display);
  }

  const std::string machine = DescribeMachine();
  const int ss = scene.optics.supersample;
  log << fmt::format(
      "bench capture: {} ({} x {} px, {}x{} supersampling, blur {}, noise {}), display: {}\n{}\n", SceneSource(a.scene),
      scene.camera.width, scene.camera.height, ss, ss, BlurName(scene.optics.blur), scene.sensor.noise ? "on" : "off",
      display_source, machine);

  const SyntheticPhoto cold = RenderSyntheticPhoto(scene, display);
  log << fmt::format(
      "first photo (builds the ray table{}): {:.0f} ms, of which rays {:.0f} ms (CPU {:.0f} ms)\n",
      cold.timing.rays_cached ? ", found cached" : "", cold.timing.total_ms(), cold.timing.rays_ms,
      cold.timing.rays_cpu_ms);
  std::vector<PhotoTiming> runs;
  std::string csv = fmt::format(
      "# curvecheck bench capture {}; {}\nrun,total_ms,total_cpu_ms,rays_ms,trace_ms,"
      "optics_ms,sensor_ms,rays_cpu_ms,trace_cpu_ms,optics_cpu_ms,sensor_cpu_ms,rays,"
      "refined_rays\n",
      a.scene, machine);
  for (int i = 0; i < a.runs; ++i) {
    const PhotoTiming t = RenderSyntheticPhoto(scene, display).timing;
    runs.push_back(t);
    log << fmt::format("run {}: {:.0f} ms (CPU {:.0f} ms)\n", i + 1, t.total_ms(), t.total_cpu_ms());
    csv +=
        fmt::format("{},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{},{}\n", i + 1,
                    t.total_ms(), t.total_cpu_ms(), t.rays_ms, t.trace_ms, t.optics_ms, t.sensor_ms,
                    t.rays_cpu_ms, t.trace_cpu_ms, t.optics_cpu_ms, t.sensor_cpu_ms, t.rays, t.refined_rays);
  }
  auto stat = [&](double PhotoTiming::*field) {
    std::vector<double> v;
    for (const PhotoTiming& t : runs) v.push_back(t.*field);
    return Summarize(v);
  };
  std::vector<double> totals, cpus;
  for (const PhotoTiming& t : runs) {
    totals.push_back(t.total_ms());
    cpus.push_back(t.total_cpu_ms());
  }
  const Spread total = Summarize(totals), cpu = Summarize(cpus);
  const int64_t rays = runs.front().rays;
  log << fmt::format(
      "median of {} runs: {:.0f} ms wall (min {:.0f}, max {:.0f}), CPU {:.0f} ms (min {:.0f}, max {:.0f}) on "
      "{} "
      "threads; {} rays ({} refined onto bumps): {:.1f} M rays/s overall, {:.1f} M rays/s CPU-second\n",
      a.runs, total.median, total.min, total.max, cpu.median, cpu.min, cpu.max, runs.front().threads, rays,
      runs.front().refined_rays, rays / (total.median * 1e3), rays / (cpu.median * 1e3));
  log << fmt::format("{:<8} {:>12} {:>8} {:>12} {:>8}\n", "stage", "median ms", "share", "CPU ms", "share");
  const std::vector<std::tuple<const char*, double PhotoTiming::*, double PhotoTiming::*>> stages = {
      {"rays", &PhotoTiming::rays_ms, &PhotoTiming::rays_cpu_ms},
      {"trace", &PhotoTiming::trace_ms, &PhotoTiming::trace_cpu_ms},
      {"optics", &PhotoTiming::optics_ms, &PhotoTiming::optics_cpu_ms},
      {"sensor", &PhotoTiming::sensor_ms, &PhotoTiming::sensor_cpu_ms}};
  double wall_sum = 0, cpu_sum = 0;
  for (const auto& [name, wall, cpu_field] : stages) {
    wall_sum += stat(wall).median;
    cpu_sum += stat(cpu_field).median;
  }
  for (const auto& [name, wall, cpu_field] : stages) {
    const double w = stat(wall).median, c = stat(cpu_field).median;
    log << fmt::format("{:<8} {:>12.0f} {:>7.0f}% {:>12.0f} {:>7.0f}%\n", name, w, 100 * w / wall_sum, c,
                       100 * c / cpu_sum);
  }
  if (!a.output.empty()) {
    WriteFileAtomic(a.output, csv);
    log << "wrote " << a.output << "\n";
  }
}

}  // namespace curvecheck::experiments
