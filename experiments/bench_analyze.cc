#include "experiments/bench_analyze.h"

#include <fmt/format.h>

#include <cmath>
#include <map>

#include "analysis/screen_fit_test_util.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/trial.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

// One seed's photo and its analysis, as a row of analyze_bench.csv.
struct SeedTrial {
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

}  // namespace

void BenchAnalyzeOptions::Check() const {
  if (seeds < 2) throw Error("--seeds", fmt::format("is {}; at least 2 are needed for a spread", seeds), "");
  // As `sweep` (SweepOptions::Check): a checkerboard has 2 or more squares; 1000 bounds the features.
  RequireInRange("--cols", "the number of squares across", cols, 2, 1000, "give 2 to 1000, e.g. 32");
  RequireInRange("--rows", "the number of squares down", rows, 2, 1000, "give 2 to 1000, e.g. 9");
}

bool RunBenchAnalyze(const BenchAnalyzeOptions& a, const fs::path& out, std::ostream& log) {
  a.Check();
  SyntheticScene scene = FindScene(a.scene, "--scene");
  const std::string scene_source = SceneSource(a.scene);
  const Monitor& m = scene.monitor;
  const Eigen::Vector3d viewpoint = scene.screen_from_cam.translation;

  PatternSpec spec;
  spec.cols = a.cols;
  spec.rows = a.rows;
  Renderer renderer;
  const TrialDisplay display = RenderTrialDisplay(renderer, m, viewpoint, spec);
  const fs::path pattern_json = out / "pattern.json";
  WriteFileAtomic(pattern_json, display.PatternJson().dump(1) + "\n");

  const double true_radius = scene.truth.curvature_per_mm != 0 ? 1 / scene.truth.curvature_per_mm : INFINITY;
  log << fmt::format(
      "bench analyze: scene {} ({}, true R = {:.1f} mm), camera {} {}x{}, {}x{} board, {} seeds\n{}\n\n",
      scene_source, m.name, true_radius, scene.camera.lensmodel, scene.camera.width, scene.camera.height,
      a.cols, a.rows, a.seeds, DescribeMachine());
  log << fmt::format("{:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>8} {:>10}  {}\n", "seed", "photo ms",
                     "detect ms", "verify ms", "fit ms", "features", "R mm", "sigma", "verif px", "chosen");

  std::vector<SeedTrial> trials;
  std::string csv =
      "seed,photo_ms,detect_ms,verify_ms,fit_ms,analysis_ms,features,verification_rms_px,chosen,"
      "cylinder_radius_mm,cylinder_sigma_mm,ci95_lo_mm,ci95_hi_mm,noise_px,failure\n";
  for (int k = 0; k < a.seeds; ++k) {
    SeedTrial t;
    t.seed = static_cast<uint64_t>(k + 1);
    scene.sensor.seed = t.seed;
    const TrialAnalysis trial = PhotographAndAnalyse(
        scene, display.image, {fmt::format("seed-{}", t.seed), pattern_json}, scene_source, AnalyzeOptions{});
    t.photo_ms = trial.photo_ms;
    const AnalysisResult& r = trial.analysis;
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
      if (const ModelFit* f = CylinderCandidate(r)) {
        t.noise_px = f->noise_px;
        if (f->radius_mm) {
          t.ok = true;
          t.radius_mm = *f->radius_mm;
          t.sigma_mm = f->radius_sigma_mm.value_or(NAN);
          t.lo_mm = f->radius_ci95_mm[0];
          t.hi_mm = f->radius_ci95_mm[1];
        } else {
          t.failure = "cylinder radius not a number (flat within its interval)";
        }
      }
      for (const FeatureCheck& c : p.verification.features) t.display_px.push_back(c.display_px);
    }
    log << fmt::format("{:>5} {:>9.0f} {:>9.1f} {:>9.1f} {:>9.1f} {:>9} {:>10.2f} {:>8.2f} {:>10.4f}  {}{}\n",
                       t.seed, t.photo_ms, t.detect_ms, t.verify_ms, t.fit_ms, t.features, t.radius_mm,
                       t.sigma_mm, t.verification_rms_px, t.chosen, t.failure.empty() ? "" : " " + t.failure);
    csv += fmt::format(
        "{},{:.1f},{:.2f},{:.2f},{:.2f},{:.1f},{},{:.5f},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.5f},\"{}\"\n",
        t.seed, t.photo_ms, t.detect_ms, t.verify_ms, t.fit_ms, t.analysis_ms, t.features,
        t.verification_rms_px, t.chosen, t.radius_mm, t.sigma_mm, t.lo_mm, t.hi_mm, t.noise_px, t.failure);
    trials.push_back(std::move(t));
  }

  // Statistics over the trials with a radius.
  std::vector<double> radius, sigma, noise, photo_ms, detect_ms, verify_ms, fit_ms, analysis_ms;
  int covered = 0;
  std::map<std::string, int> chosen;
  const SeedTrial* example = nullptr;
  for (const SeedTrial& t : trials) {
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
      bound = RadiusCramerRaoBoundMm(true_monitor, scene.camera, {testing::ScenePose(scene)},
                                     {example->display_px}, mean_noise);
    }
    std::string models;
    for (const auto& [name, count] : chosen)
      models += fmt::format("{}{} x{}", models.empty() ? "" : ", ", name, count);
    summary = fmt::format(
        "cylinder radius over {} of {} seeds: mean {:.2f} mm, truth {:.2f} mm, bias {:+.2f} mm = {:+.2f} "
        "sigma "
        "(standard error of the mean {:.2f} mm)\n"
        "  empirical sigma {:.2f} mm; mean reported sigma {:.2f} mm (ratio {:.2f}); Cramer-Rao bound {:.2f} "
        "mm at "
        "{:.3f} px noise (empirical / bound {:.2f})\n"
        "  95% intervals cover the truth in {} of {} ({:.0f}%)\n"
        "  chosen model: {}\n"
        "median times: photo {:.0f} ms, detect {:.1f} ms, verify {:.1f} ms, fit (all models) {:.1f} ms, "
        "analysis "
        "{:.1f} ms\n",
        n, trials.size(), mean, true_radius, mean - true_radius, (mean - true_radius) / mean_sigma,
        sd / std::sqrt(n), sd, mean_sigma, sd / mean_sigma, bound, mean_noise, sd / bound, covered, n,
        100.0 * covered / n, models, Median(photo_ms), Median(detect_ms), Median(verify_ms), Median(fit_ms),
        Median(analysis_ms));
  } else {
    summary = fmt::format("only {} of {} seeds gave a radius; no statistics\n", n, trials.size());
  }
  log << "\n" << summary;
  WriteFileAtomic(out / "analyze_bench.csv", csv);
  WriteFileAtomic(out / "analyze_bench.txt",
                  fmt::format("curvecheck bench analyze --scene {} --seeds {}\n{}\n\n{}", a.scene, a.seeds,
                              DescribeMachine(), summary));
  log << fmt::format("wrote {}/analyze_bench.csv and analyze_bench.txt\n", out.string());
  return n >= 2;
}

}  // namespace curvecheck::experiments
