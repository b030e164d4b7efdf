// `curvecheck bench fit`, `bench models`, `bench analyze` and `bench verdict`: the screen fit, the whole analysis
// and the verification's verdict on synthetic truth. Each parses and validates its options and calls its bench in
// experiments/ (bench_fit.h, bench_models.h, bench_analyze.h, bench_verdict.h).

#include <filesystem>
#include <iostream>
#include <memory>

#include "app/bench_command.h"
#include "app/cli.h"
#include "app/output_paths.h"
#include "experiments/bench_analyze.h"
#include "experiments/bench_fit.h"
#include "experiments/bench_models.h"
#include "experiments/bench_verdict.h"

namespace curvecheck::app {
namespace {

void AddBenchFit(CLI::App& bench, std::function<int()>& run) {
  auto o = std::make_shared<experiments::BenchFitOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "fit",
      "Screen fit on synthetic truth: time per model (1 and 10 photos), radius bias/scatter/CRB/coverage");
  cmd->add_option("--scene", o->scene, "Scene file (its true monitor and camera)")->capture_default_str();
  cmd->add_option("--runs", o->runs, "Timed runs per case (median reported)")->capture_default_str();
  cmd->add_option("--seeds", o->seeds, "Seeded single-photo fits for the radius statistics")
      ->capture_default_str();
  cmd->add_option("--noise", o->noise_px, "Detection noise, px per coordinate")->capture_default_str();
  cmd->callback([&run, o] {
    run = [o] {
      experiments::RunBenchFit(*o, std::cout);
      return 0;
    };
  });
}

struct BenchModelsArgs {
  experiments::BenchModelsOptions options;
  std::string scenes = "default,radius-8pct,lean-1deg,bulge-2mm";  // comma-separated
  std::string output = "bench-out";
};

void AddBenchModels(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchModelsArgs>();
  experiments::BenchModelsOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "models",
      "Every screen model on several true screens: fit time vs radius error and surface error; CSV + chart");
  cmd->add_option("--scenes", a->scenes, "Comma-separated scene names (files in --scenes-dir)")
      ->capture_default_str();
  cmd->add_option("--scenes-dir", o.scenes_dir,
                  "Folder of the scene YAML files (default: the embedded datasets/scenes)");
  cmd->add_option("--seeds", o.seeds, "Noise seeds per case (times: median over them)")
      ->capture_default_str();
  cmd->add_option("--noise", o.noise_px, "Detection noise, px per coordinate")->capture_default_str();
  cmd->add_option("--grid-cols", o.grid_cols, "Features across the width")->capture_default_str();
  cmd->add_option("--grid-rows", o.grid_rows, "Features down the height")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  cmd->callback([&run, a] {
    run = [a] {
      a->options.scenes = SplitList(a->scenes);
      a->options.Check();
      CreateBenchFolder(a->output);
      experiments::RunBenchModels(a->options, a->output, std::cout);
      return 0;
    };
  });
}

struct BenchAnalyzeArgs {
  experiments::BenchAnalyzeOptions options;
  std::string output = "bench-analyze";
};

void AddBenchAnalyze(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchAnalyzeArgs>();
  experiments::BenchAnalyzeOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "analyze",
      "The whole analysis on synthetic photos of a scene, many noise seeds: radius bias, sigma against "
      "the Cramer-Rao bound, interval coverage, model choice, time per stage");
  cmd->add_option("--scene", o.scene, "Scene YAML, or the name of an embedded scene")->capture_default_str();
  cmd->add_option("--seeds", o.seeds, "Photos (noise seeds)")->capture_default_str();
  cmd->add_option("--cols", o.cols, "Checkerboard squares across")->capture_default_str();
  cmd->add_option("--rows", o.rows, "Checkerboard squares down")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  cmd->callback([&run, a] {
    run = [a] {
      a->options.Check();
      PrepareOutputDir(a->output, "-o");
      return experiments::RunBenchAnalyze(a->options, a->output, std::cout) ? 0 : 1;
    };
  });
}

struct BenchVerdictArgs {
  experiments::BenchVerdictOptions options;
  std::string views = "on-axis,off-axis";
  std::string output = "bench-verdict";
};

void AddBenchVerdict(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchVerdictArgs>();
  experiments::BenchVerdictOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "verdict",
      "The verification's verdict (pass / fail / inconclusive) against the truth on seeded synthetic trials: "
      "correct corrections, a viewpoint misstated by 25 mm and a true 1080R under a 1000R rendering, across "
      "resolution scales and distances; confusion matrix, false-fail and false-pass rates with Wilson 95% "
      "intervals");
  cmd->add_option("--trials", o.trials, "Seeded trials per cell (distance, view, case, scale)")
      ->capture_default_str();
  cmd->add_option("--seed", o.seed, "Noise seed of the first trial; trial k uses seed + k")->capture_default_str();
  cmd->add_option("--scales", o.scales, "Resolution scales of the scene's camera, comma-separated, in (0, 1]")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--distances", o.distances_mm,
                  "Camera distances from the screen centre, mm, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--views", a->views, "on-axis, off-axis (yaw 15 deg, pitch 5 deg) or both, comma-separated")
      ->capture_default_str();
  cmd->add_option("--scene", o.scene, "Scene YAML, or the name of an embedded scene (its monitor, lens, optics, "
                                      "sensor; the camera is placed by the bench)")
      ->capture_default_str();
  cmd->add_option("--tolerance", o.tolerance_display_px, "Tolerance T, display px")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder (verdict_bench.csv, .json, .txt)")->capture_default_str();
  cmd->callback([&run, a] {
    run = [a] {
      a->options.views = SplitList(a->views);
      a->options.command_line = CommandLine();
      a->options.Check();
      PrepareOutputDir(a->output, "-o");
      experiments::RunBenchVerdict(a->options, a->output, std::cout);
      return 0;
    };
  });
}

}  // namespace

void AddBenchAnalysisCommands(CLI::App& bench, std::function<int()>& run) {
  AddBenchFit(bench, run);
  AddBenchModels(bench, run);
  AddBenchAnalyze(bench, run);
  AddBenchVerdict(bench, run);
}

}  // namespace curvecheck::app
