// `curvecheck bench fit`, `bench models` and `bench analyze`: the screen fit and the whole analysis on
// synthetic truth. Each parses and validates its options and calls its bench in experiments/ (bench_fit.h,
// bench_models.h, bench_analyze.h).

#include <filesystem>
#include <iostream>
#include <memory>

#include "app/bench_command.h"
#include "app/cli.h"
#include "app/output_paths.h"
#include "experiments/bench_analyze.h"
#include "experiments/bench_fit.h"
#include "experiments/bench_models.h"

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

}  // namespace

void AddBenchAnalysisCommands(CLI::App& bench, std::function<int()>& run) {
  AddBenchFit(bench, run);
  AddBenchModels(bench, run);
  AddBenchAnalyze(bench, run);
}

}  // namespace curvecheck::app
