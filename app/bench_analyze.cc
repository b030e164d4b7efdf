// `curvecheck bench analyze`: the accuracy and speed of the whole analysis on synthetic truth (issue 6 items 7
// and 8). One corrected checkerboard is rendered for the scene's camera position; then, for each seed, the
// synthetic camera takes a new photo (only the sensor noise differs) and the photo is analysed from pixels:
// detection, verification, the screen fit of every model. Reported: the `cylinder` candidate's radius against
// the truth (bias in mm and in sigmas, the empirical sigma against the mean reported sigma and the Cramer-Rao
// bound at the truth, the coverage of the 95% intervals), the model chosen, and the median time of each stage.
//
// The seeds share everything but the noise: the renderer's anti-aliasing and the detector's systematic errors are
// the same in every photo, so a bias they cause shows as bias here, which is what a user would meet.
#include "app/bench_analyze.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>

#include "analysis/pipeline.h"
#include "app/bench_util.h"
#include "app/machine_info.h"
#include "app/output_paths.h"
#include "synth/synthetic_camera.h"
#include "core/correction.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "datasets/dataset_files.h"
#include "pattern/pattern_json.h"
#include "render/renderer.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct BenchAnalyzeArgs {
  std::string scene = "default";
  int seeds = 20;
  int cols = 32, rows = 9;
  std::string output = "bench-analyze";
};

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Trial {
  uint64_t seed = 0;
  double photo_ms = 0, detect_ms = 0, verify_ms = 0, fit_ms = 0, analysis_ms = 0;
  bool ok = false;
  std::string failure;
  int features = 0;
  double verification_rms_px = 0;
  std::string chosen;
  double radius_mm = std::nan(""), sigma_mm = std::nan(""), lo_mm = std::nan(""), hi_mm = std::nan("");
  double noise_px = std::nan("");
  std::vector<Eigen::Vector2d> display_px;  // of the fitted features (for the bound)
};

int RunBenchAnalyze(const BenchAnalyzeArgs& a) {
  if (a.seeds < 2) throw Error("--seeds", fmt::format("is {}; at least 2 are needed for a spread", a.seeds), "");
  const fs::path out = a.output;
  PrepareOutputDir(out, "-o");
  fs::path scene_path = a.scene;
  std::error_code ec;
  if (!fs::exists(scene_path, ec)) {
    WriteDatasetFiles(out / "datasets");
    scene_path = out / "datasets" / "scenes" / (a.scene + ".yaml");
    if (!fs::exists(scene_path, ec)) {
      throw Error("--scene", fmt::format("'{}' is neither a file nor an embedded scene", a.scene),
                  "give a scene YAML or a name from datasets/scenes/ (default, off-axis, radius-8pct, ...)");
    }
  }
  SyntheticScene scene = LoadScene(scene_path);
  const Monitor& m = scene.monitor;
  const Eigen::Vector3d viewpoint = scene.camera_position_in_screen;

  PatternSpec spec;
  spec.cols = a.cols;
  spec.rows = a.rows;
  const Pattern pattern = BuildPattern(spec, m, viewpoint, TangentPlaneAtCentre(m));
  Renderer renderer;
  const RenderOptions render_options;
  const GrayImage gray = renderer.Render(m, viewpoint, pattern, render_options);
  const fs::path pattern_json = out / "pattern.json";
  WriteFileAtomic(pattern_json, PatternToJson(pattern, m, viewpoint, render_options.method.ToJson()).dump(1) + "\n");
  Image8 display;
  display.width = gray.width;
  display.height = gray.height;
  display.channels = 1;
  display.pixels = gray.pixels;

  const double true_radius = scene.truth.curvature_per_mm != 0 ? 1 / scene.truth.curvature_per_mm : INFINITY;
  std::cout << fmt::format("bench analyze: scene {} ({}, true R = {:.1f} mm), camera {} {}x{}, {}x{} board, {} seeds\n{}\n\n",
                           scene_path.string(), m.name, true_radius, scene.camera.lensmodel, scene.camera.width,
                           scene.camera.height, a.cols, a.rows, a.seeds, DescribeMachine());
  std::cout << fmt::format("{:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>8} {:>10}  {}\n", "seed", "photo ms",
                           "detect ms", "verify ms", "fit ms", "features", "R mm", "sigma", "verif px", "chosen");

  std::vector<Trial> trials;
  std::string csv = "seed,photo_ms,detect_ms,verify_ms,fit_ms,analysis_ms,features,verification_rms_px,chosen,"
                    "cylinder_radius_mm,cylinder_sigma_mm,ci95_lo_mm,ci95_hi_mm,noise_px,failure\n";
  for (int k = 0; k < a.seeds; ++k) {
    Trial t;
    t.seed = static_cast<uint64_t>(k + 1);
    scene.sensor.seed = t.seed;
    auto t0 = std::chrono::steady_clock::now();
    const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display);
    t.photo_ms = MsSince(t0);
    const cv::Mat image = PhotoToMat(photo);
    const AnalysisResult r = AnalyzeImages(scene.camera, scene_path, {{fmt::format("seed-{}", t.seed), pattern_json}},
                                           {image}, AnalyzeOptions{});
    const PhotoAnalysis& p = r.photos.front();
    t.detect_ms = p.detection.time_ms;
    t.verify_ms = p.verify_ms;
    t.fit_ms = r.fit_ms;
    t.analysis_ms = r.total_ms;
    t.features = static_cast<int>(p.fit_ids.size());
    if (!p.used) {
      t.failure = p.rejected;
    } else if (!r.fit) {
      t.failure = r.fit_failure;
    } else {
      t.verification_rms_px = p.verification.rms_px;
      t.chosen = r.fit->Chosen().model;
      for (const ModelFit& f : r.fit->candidates) {
        if (f.model != "cylinder") continue;
        t.noise_px = f.noise_px;
        if (f.radius_mm) {
          t.ok = true;
          t.radius_mm = *f.radius_mm;
          t.sigma_mm = f.radius_sigma_mm.value_or(NAN);
          t.lo_mm = f.radius_ci95_mm[0];
          t.hi_mm = f.radius_ci95_mm[1];
        } else {
          t.failure = "cylinder radius not a number (flat within its interval)";
        }
      }
      for (const FeatureCheck& c : p.verification.features) t.display_px.push_back(c.display_px);
    }
    std::cout << fmt::format("{:>5} {:>9.0f} {:>9.1f} {:>9.1f} {:>9.1f} {:>9} {:>10.2f} {:>8.2f} {:>10.4f}  {}{}\n",
                             t.seed, t.photo_ms, t.detect_ms, t.verify_ms, t.fit_ms, t.features, t.radius_mm,
                             t.sigma_mm, t.verification_rms_px, t.chosen, t.failure.empty() ? "" : " " + t.failure);
    csv += fmt::format("{},{:.1f},{:.2f},{:.2f},{:.2f},{:.1f},{},{:.5f},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.5f},\"{}\"\n",
                       t.seed, t.photo_ms, t.detect_ms, t.verify_ms, t.fit_ms, t.analysis_ms, t.features,
                       t.verification_rms_px, t.chosen, t.radius_mm, t.sigma_mm, t.lo_mm, t.hi_mm, t.noise_px,
                       t.failure);
    trials.push_back(std::move(t));
  }

  // Statistics over the trials with a radius.
  std::vector<double> radius, sigma, noise, photo_ms, detect_ms, verify_ms, fit_ms, analysis_ms;
  int covered = 0;
  std::map<std::string, int> chosen;
  const Trial* example = nullptr;
  for (const Trial& t : trials) {
    photo_ms.push_back(t.photo_ms);
    detect_ms.push_back(t.detect_ms);
    verify_ms.push_back(t.verify_ms);
    fit_ms.push_back(t.fit_ms);
    analysis_ms.push_back(t.analysis_ms);
    if (!t.chosen.empty()) ++chosen[t.chosen];
    if (!t.ok) continue;
    radius.push_back(t.radius_mm);
    sigma.push_back(t.sigma_mm);
    noise.push_back(t.noise_px);
    covered += (true_radius >= t.lo_mm && true_radius <= t.hi_mm) ? 1 : 0;
    if (!example) example = &t;
  }
  const int n = static_cast<int>(radius.size());
  std::string summary;
  if (n >= 2) {
    double mean = 0, mean_sigma = 0, mean_noise = 0;
    for (int i = 0; i < n; ++i) {
      mean += radius[i] / n;
      mean_sigma += sigma[i] / n;
      mean_noise += noise[i] / n;
    }
    double var = 0;
    for (double r : radius) var += (r - mean) * (r - mean) / (n - 1);
    const double sd = std::sqrt(var);
    // The bound at the truth, for the features of one trial and the measured noise.
    double bound = NAN;
    if (scene.truth.curvature_per_mm != 0) {
      Monitor true_monitor = m;
      true_monitor.curvature_per_mm = scene.truth.curvature_per_mm;
      CentrePose pose;
      pose.centre_from_cam = scene.screen_from_cam;
      pose.position_in_centre_mm = viewpoint - ScreenCentreInScreen(m);
      bound = RadiusCramerRaoBoundMm(true_monitor, scene.camera, {pose}, {example->display_px}, mean_noise);
    }
    std::string models;
    for (const auto& [name, count] : chosen) models += fmt::format("{}{} x{}", models.empty() ? "" : ", ", name, count);
    summary = fmt::format(
        "cylinder radius over {} of {} seeds: mean {:.2f} mm, truth {:.2f} mm, bias {:+.2f} mm = {:+.2f} sigma "
        "(standard error of the mean {:.2f} mm)\n"
        "  empirical sigma {:.2f} mm; mean reported sigma {:.2f} mm (ratio {:.2f}); Cramer-Rao bound {:.2f} mm at "
        "{:.3f} px noise (empirical / bound {:.2f})\n"
        "  95% intervals cover the truth in {} of {} ({:.0f}%)\n"
        "  chosen model: {}\n"
        "median times: photo {:.0f} ms, detect {:.1f} ms, verify {:.1f} ms, fit (all models) {:.1f} ms, analysis "
        "{:.1f} ms\n",
        n, trials.size(), mean, true_radius, mean - true_radius, (mean - true_radius) / mean_sigma,
        sd / std::sqrt(n), sd, mean_sigma, sd / mean_sigma, bound, mean_noise, sd / bound, covered, n,
        100.0 * covered / n, models, Median(photo_ms), Median(detect_ms), Median(verify_ms), Median(fit_ms),
        Median(analysis_ms));
  } else {
    summary = fmt::format("only {} of {} seeds gave a radius; no statistics\n", n, trials.size());
  }
  std::cout << "\n" << summary;
  WriteFileAtomic(out / "analyze_bench.csv", csv);
  WriteFileAtomic(out / "analyze_bench.txt", fmt::format("curvecheck bench analyze --scene {} --seeds {}\n{}\n\n{}",
                                                           a.scene, a.seeds, DescribeMachine(), summary));
  std::cout << fmt::format("wrote {}/analyze_bench.csv and analyze_bench.txt\n", out.string());
  return n >= 2 ? 0 : 1;
}

}  // namespace

void AddBenchAnalyzeCommand(CLI::App& bench, std::function<int()>& run) {
  auto args = std::make_shared<BenchAnalyzeArgs>();
  CLI::App* cmd = bench.add_subcommand(
      "analyze", "The whole analysis on synthetic photos of a scene, many noise seeds: radius bias, sigma against "
                 "the Cramer-Rao bound, interval coverage, model choice, time per stage");
  cmd->add_option("--scene", args->scene, "Scene YAML, or the name of an embedded scene")->capture_default_str();
  cmd->add_option("--seeds", args->seeds, "Photos (noise seeds)")->capture_default_str();
  cmd->add_option("--cols", args->cols, "Checkerboard squares across")->capture_default_str();
  cmd->add_option("--rows", args->rows, "Checkerboard squares down")->capture_default_str();
  cmd->add_option("-o,--output", args->output, "Output folder")->capture_default_str();
  cmd->callback([&run, args] { run = [args] { return RunBenchAnalyze(*args); }; });
}

}  // namespace curvecheck::app
