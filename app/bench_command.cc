// `curvecheck bench`: the benchmark subcommands. Each parses and validates its options and calls its bench in
// experiments/ (bench_render.h, bench_capture.h, bench_detect.h, bench_calibrate.h; the others in
// app/bench_analysis_command.cc).
#include "app/bench_command.h"

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>

#include "core/output_paths.h"
#include "app/render_options.h"
#include "core/error.h"
#include "experiments/bench_calibrate.h"
#include "experiments/bench_flat_vs_board.h"
#include "experiments/bench_self_calibrate.h"
#include "experiments/bench_capture.h"
#include "experiments/bench_detect.h"
#include "experiments/bench_render.h"
#include "experiments/scene_lookup.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct BenchRenderArgs {
  SceneArgs scene;
  experiments::BenchRenderOptions options;
  std::string output = "bench-out";
};

void AddBenchRender(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchRenderArgs>();
  CLI::App* cmd = bench.add_subcommand(
      "render",
      "Every correction method and setting: render time vs mapping error; CSV + chart with the Pareto front");
  AddSceneOptions(*cmd, a->scene, "1 m in front of the screen centre (the axis of a 1000R panel)");
  cmd->add_option("--runs", a->options.runs, "Timed runs per setting (median reported)")
      ->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  cmd->add_flag("--quick", a->options.quick, "A reduced set of settings (for smoke tests)");
  cmd->callback([&run, a] {
    run = [a] {
      a->options.Check();
      const Scene scene = ResolveScene(a->scene, Eigen::Vector3d(0, 0, 1000));
      CreateBenchFolder(a->output);
      experiments::RunBenchRender(scene.monitor, scene.viewpoint_in_screen, scene.spec, a->options, a->output,
                                  std::cout);
      return 0;
    };
  });
}

void AddBenchCapture(CLI::App& bench, std::function<int()>& run) {
  auto o = std::make_shared<experiments::BenchCaptureOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "capture", "Synthetic camera speed on one scene: median wall and CPU time, rays/s, share per stage");
  cmd->add_option("--scene", o->scene, experiments::SceneOptionHelp())->capture_default_str();
  cmd->add_option(
      "--display", o->display,
      "Display image (PNG at the monitor's resolution); default: the default checkerboard rendered "
      "for the camera position (Vulkan)");
  cmd->add_option("--runs", o->runs, "Timed runs after the first (median reported)")->capture_default_str();
  cmd->add_option("-o,--output", o->output, "CSV of every run (optional)");
  cmd->callback([&run, o] {
    run = [o] {
      o->Check();
      if (!o->output.empty()) {
        // The CSV never replaces the scene or the display it photographs, and its folder takes it, before the runs.
        std::vector<fs::path> inputs = {o->scene};
        if (!o->display.empty()) inputs.push_back(o->display);
        CheckOutputs({{"-o", o->output}}, inputs);
        CheckWritable(o->output);
      }
      experiments::RunBenchCapture(*o, std::cout);
      return 0;
    };
  });
}

struct BenchDetectArgs {
  experiments::BenchDetectOptions options;
  std::string output = "bench-out";
};

void AddBenchDetect(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchDetectArgs>();
  experiments::BenchDetectOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "detect", "Every detector on synthetic photos of a scene: median time and error against the truth");
  cmd->add_option("--scene", o.scene, experiments::SceneOptionHelp() + "; its camera takes the photos")->capture_default_str();
  cmd->add_option("--runs", o.runs, "Timed runs per detector (median reported)")->capture_default_str();
  cmd->add_option("--patterns", o.patterns, "Which of checkerboard,square,apriltag")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder (detect_bench.csv, detect_bench.png and its .gp)");
  cmd->add_flag("--uniform-display", o.uniform_display,
                "Display pixels uniform (fill factor 1, no RGB stripes) and 4x4 supersampling: no moire");
  cmd->callback([&run, a] {
    run = [a] {
      a->options.Check();
      CreateBenchFolder(a->output);
      experiments::RunBenchDetect(a->options, a->output, std::cout);
      return 0;
    };
  });
}

struct BenchCalibrateArgs {
  experiments::BenchCalibrateOptions options;
  std::string output = "bench-calibrate";
  bool from_screen = false, flat_vs_board = false;
  experiments::BenchSelfCalibrateOptions screen;
};

void AddBenchCalibrate(CLI::App& bench, std::function<int()>& run) {
  auto a = std::make_shared<BenchCalibrateArgs>();
  experiments::BenchCalibrateOptions& o = a->options;
  CLI::App* cmd = bench.add_subcommand(
      "calibrate",
      "Lens models on a synthetic set with a known lens: calibration time vs error against the truth");
  cmd->add_option("--runs", o.runs, "Timed calibrations per lens model (median reported)")
      ->capture_default_str();
  cmd->add_option("--views", o.views, "Photos in the synthetic set")->capture_default_str();
  cmd->add_option("--seed", o.seed, "Seed of the set's poses and noise")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  cmd->add_flag("--quick", o.quick, "12 views and one splined density (for smoke tests)");
  cmd->add_flag("--from-screen", a->from_screen,
                "Bench the calibration from the screen instead (calibrate --from-screen): seeded trials of 8-12 "
                "realistic photos of the monitor; lens error against the truth and radius coverage");
  cmd->add_option("--trials", a->screen.trials, "With --from-screen: trials")->capture_default_str();
  cmd->add_option("--scale", a->screen.scale, "With --from-screen: imager scale")->capture_default_str();
  cmd->add_option("--scene", a->screen.scene, "With --from-screen: the scene")->capture_default_str();
  cmd->add_flag("--ignore-advice", [a](int64_t) { a->screen.follow_advice = false; },
                "With --from-screen: do not add the suggested photos when the precision check fails");
  cmd->add_flag("--flat-vs-board", a->flat_vs_board,
                "Compare calibrate --from-screen on a flat monitor with a board calibration of the same synthetic "
                "camera, against both calibrations' uncertainties (--trials, --seed, --scale, --scene act)");
  cmd->callback([&run, a] {
    if (a->flat_vs_board) {
      run = [a] {
        experiments::BenchFlatVsBoardOptions f;
        f.trials = a->screen.trials;
        f.seed = a->options.seed;
        f.scale = a->screen.scale;
        f.scene = a->screen.scene;
        f.Check();
        CreateBenchFolder(a->output);
        experiments::RunBenchFlatVsBoard(f, a->output, std::cout);
        return 0;
      };
      return;
    }
    if (a->from_screen) {
      run = [a] {
        a->screen.seed = a->options.seed;
        a->screen.Check();
        CreateBenchFolder(a->output);
        experiments::RunBenchSelfCalibrate(a->screen, a->output, std::cout);
        return 0;
      };
      return;
    }
    if (a->options.quick) {
      a->options.views = std::min(a->options.views, 12);
      a->options.splined_nx = {8};
    }
    run = [a] {
      a->options.Check();
      CreateBenchFolder(a->output);
      experiments::RunBenchCalibrate(a->options, a->output, std::cout);
      return 0;
    };
  });
}

}  // namespace

void CreateBenchFolder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw Error(dir.string(), "cannot create the output folder", "choose a writable path");
}

void AddBenchCommand(CLI::App& app, std::function<int()>& run) {
  CLI::App* bench =
      app.add_subcommand("bench", "Speed against accuracy benchmarks (medians of several runs)");
  bench->require_subcommand(1);
  AddBenchRender(*bench, run);
  AddBenchCapture(*bench, run);
  AddBenchDetect(*bench, run);
  AddBenchAnalysisCommands(*bench, run);
  AddBenchCalibrate(*bench, run);
}

}  // namespace curvecheck::app
