// `curvecheck bench fit`, `bench models`, `bench analyze`, `bench verdict` and `bench validity`: the screen fit, the
// whole analysis, the verification's verdict and the honesty of the radius interval on synthetic truth. Each parses
// and validates its options and calls its bench in experiments/ (bench_fit.h, bench_models.h, bench_analyze.h,
// bench_verdict.h, bench_validity.h).

#include <filesystem>
#include <iostream>
#include <memory>
#include <tuple>

#include "app/bench_command.h"
#include "app/cli.h"
#include "core/config.h"
#include "core/output_paths.h"
#include "experiments/bench_analyze.h"
#include "experiments/bench_fit.h"
#include "experiments/bench_models.h"
#include "experiments/bench_validity.h"
#include "experiments/bench_verdict.h"
#include "experiments/scene_lookup.h"
#include "render/scene_args.h"

namespace curvecheck::app {
namespace {

void AddBenchFit(CLI::App& bench, std::function<int()>& run) {
  auto o = std::make_shared<experiments::BenchFitOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "fit",
      "Screen fit on synthetic truth: time per model (1 and 10 photos), radius bias/scatter/CRB/coverage");
  cmd->add_option("--scene", o->scene, experiments::SceneOptionHelp() + "; its true monitor and camera")->capture_default_str();
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
  cmd->add_option("--scene", o.scene, experiments::SceneOptionHelp())->capture_default_str();
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
  cmd->add_option("--scene", o.scene, experiments::SceneOptionHelp() + " (its monitor, lens, optics, "
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

struct BenchValidityArgs {
  experiments::BenchValidityOptions options;
  std::string realism = "off,on";
  std::string shard = "1/1";
  std::string tags = "16x4";
  std::string output = "bench-validity";
};

struct BenchValidityMergeArgs {
  std::vector<std::string> dirs;
  std::string output;
};

const std::vector<const char*> kValidityOutputs = {"validity_trials.csv", "validity.csv", "validity.json",
                                                   "validity.txt"};

void AddBenchValidity(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchValidityArgs>();
  auto m = std::make_shared<BenchValidityMergeArgs>();
  experiments::BenchValidityOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "validity",
      "Is the radius interval honest? Seeded trials of the whole chain over resolution scale, distance, yaw, "
      "realistic imaging on/off and the true radius (+-8%); per cell bias in sigmas, scatter / sigma, coverage of "
      "the 68% and 95% intervals (Wilson 95% intervals), for the radius and the camera position; CSV, JSON, table, "
      "chart; shards and `bench validity merge`. Exit 0 when the bench ran, whatever the cells show");
  cmd->add_option("--trials", o.trials, "Seeded trials per cell")->capture_default_str();
  cmd->add_option("--seed", o.seed, "Seed of the first trial; trial k uses seed + k (noise and pose jitter)")
      ->capture_default_str();
  cmd->add_option("--scales", o.scales, "Resolution scales of the scene's camera, comma-separated, in (0, 1]")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--distances-mm", o.distances_mm, "Camera distances from the screen centre, mm, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--yaws-deg", o.yaws_deg,
                  "Camera yaws around the screen centre, deg, comma-separated (positive: to the right)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--realism", a->realism, "Imaging chain: off (imaging.preset=clean), on (imaging.preset=ilc24: Bayer, JPEG, defocus, panel fall-off, glare), or off,on; a level may add scene overrides after '+', e.g. on+imaging.cfa=none (an ablation)")
      ->capture_default_str();
  cmd->add_option("--radius-factors", o.radius_factors,
                  "True radius as factors of the nominal, comma-separated (the pattern is rendered for the nominal)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--scene", o.scene,
                  experiments::SceneOptionHelp() + " (its monitor, lens, optics, sensor; the bench places the camera)")
      ->capture_default_str();
  cmd->add_option("--jitter-mm", o.jitter_mm, "Camera position jitter per trial, mm per axis (1 sigma)")
      ->capture_default_str();
  cmd->add_option("--pitch-tolerance", o.pitch_tolerance_percent,
                  "The true pixel pitch is drawn per trial uniformly within +-this percent of the datasheet's, and "
                  "the analysis is given this tolerance (analyze --pitch-tolerance, whose default it is); 0 = the "
                  "datasheet's exactly and no pitch row: the budget's other rows tested alone")
      ->capture_default_str();
  cmd->add_option("--lens-misfit-stated", o.lens_misfit_stated,
                  "The analysis is told the true lens's misfit (RMS times this factor, and its length) as its "
                  "calibration's measurement (analyze --lens-misfit; curvecheck calibrate writes it beside the "
                  "model): 1 = measured exactly, 0 = not told (the misfit row from the photo's residuals alone)")
      ->capture_default_str();
  cmd->add_option("--jitter-deg", o.jitter_deg, "Camera aim jitter per trial, deg per axis (1 sigma)")
      ->capture_default_str();
  cmd->add_flag("--correct-pixel-locking", o.correct_pixel_locking,
                "Analyse with the pixel-locking removed before the fit (analyze --correct-pixel-locking)");
  cmd->add_option("--pixel-locking-prior", o.pixel_locking_prior_px,
                  "The analysis's prior standard deviation of each pixel-locking coefficient, px (analyze "
                  "--pixel-locking-prior; 0: none, an ablation)")
      ->capture_default_str();
  cmd->add_flag("--detector-effect", o.detector_effect,
                "Also measure the radius shift the detector's systematic error caused: each trial photographed again "
                "without sensor noise, its detections' errors against the truth taken from the trial's detections, "
                "the fit repeated; validity_trials.csv sys_shift_mm beside the budget's row 2 parts "
                "(smooth_share_mm, locking_share_mm). A second photo and two more fits per trial");
  cmd->add_option("--pattern", o.pattern,
                  "The pattern shown: checkerboard (32x9 squares) or apriltag (a grid of tag36h11 tags, --tags)")
      ->capture_default_str();
  cmd->add_option("--tags", a->tags, "With --pattern apriltag: tags across x down (default 16x4)");
  cmd->add_flag("--keep-results", o.keep_results,
                "Keep every trial's result.json in OUT/results (every candidate's fit, budget and model choice)");
  cmd->add_option("--shard", a->shard, "Run only shard i of n (trials k with k mod n = i - 1)")->capture_default_str();
  cmd->add_option("-o,--output", a->output,
                  "Output folder (validity_trials.csv, validity.csv, .json, .txt, .png)")
      ->capture_default_str();
  CLI::App* merge =
      cmd->add_subcommand("merge", "Merge validity bench shards (folders, or one folder holding them) into one");
  merge->add_option("dirs", m->dirs, "Shard output folders, or a folder whose subfolders are shards")->required();
  merge->add_option("-o,--output", m->output, "Output folder of the merged bench")->required();
  merge->callback([&run, m] {
    run = [m] {
      const std::vector<std::filesystem::path> dirs =
          experiments::ShardDirs(m->dirs, experiments::ValidityShardFiles());
      std::vector<std::filesystem::path> inputs;
      for (const std::filesystem::path& d : dirs) {
        for (const char* name : kValidityOutputs) inputs.push_back(d / name);
      }
      PrepareOutputDir(m->output, "-o");
      for (const char* name : kValidityOutputs) CheckNotAnInput(std::filesystem::path(m->output) / name, inputs);
      experiments::MergeBenchValidity(dirs, m->output, CommandLine(), std::cout);
      return 0;
    };
  });
  cmd->callback([&run, a, merge] {
    if (merge->parsed()) return;
    run = [a] {
      a->options.realism = SplitList(a->realism);
      a->options.shard = experiments::ParseShard(a->shard);
      std::tie(a->options.tag_cols, a->options.tag_rows) = ParseCount2(a->tags, "--tags");
      a->options.command_line = CommandLine();
      a->options.Check();
      std::vector<std::filesystem::path> inputs;
      std::error_code ec;
      if (std::filesystem::exists(a->options.scene, ec)) inputs.emplace_back(a->options.scene);
      PrepareOutputDir(a->output, "-o");
      for (const char* name : kValidityOutputs) CheckNotAnInput(std::filesystem::path(a->output) / name, inputs);
      experiments::RunBenchValidity(a->options, a->output, std::cout);
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
  AddBenchValidity(bench, run);
}

}  // namespace curvecheck::app
