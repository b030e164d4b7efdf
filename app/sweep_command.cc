// `curvecheck sweep` (issue 7 items 3-4): stability sweeps over one or two scene factors and `sweep merge` of
// their shards. The sweep itself is experiments/sweep.h; this file parses and validates the options.
#include "app/sweep_command.h"

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "app/cli.h"
#include "core/config.h"
#include "core/output_paths.h"
#include "core/error.h"
#include "experiments/scene_lookup.h"
#include "experiments/sweep.h"
#include "render/method.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

// The options that need parsing; the rest bind straight to `options`.
struct SweepArgs {
  std::vector<std::string> factors;  // NAME=start:stop:count
  std::string method = "exact";      // a method, a comma list, or all
  std::string shard = "1/1";         // i/n
  std::string models = "flat,cylinder";
  std::string output = "sweep";
  experiments::SweepOptions options;
};

struct MergeArgs {
  std::vector<std::string> dirs;
  std::string output;
};

const std::vector<const char*> kOutputs = {"sweep.csv", "sweep.json", "sweep.txt"};

void CheckOutputs(const fs::path& out, const std::vector<fs::path>& inputs) {
  for (const char* name : kOutputs) CheckNotAnInput(out / name, inputs);
}

int RunSweep(const SweepArgs& a) {
  experiments::SweepOptions o = a.options;
  if (a.factors.empty() || a.factors.size() > 2) {
    throw Error("--factor", fmt::format("{} factors given", a.factors.size()),
                "give one or two, e.g. --factor yaw=0:40:5 --factor distance=800:2000:4");
  }
  for (const std::string& f : a.factors) o.factors.push_back(experiments::ParseFactor(f));
  if (o.factors.size() == 2 && o.factors[0].name == o.factors[1].name) {
    throw Error("--factor", "the same factor twice", "give two different factors");
  }
  if (a.method == "all") {
    o.methods = {"exact", "none", "strips", "warp", "mesh"};
  } else {
    for (const std::string& m : SplitList(a.method))
      o.methods.push_back(MethodName(ParseMethod(m, "--method")));
  }
  if (o.methods.empty())
    throw Error("--method", "no method given", "give exact, none, strips, warp, mesh or all");
  const experiments::Shard shard = experiments::ParseShard(a.shard);
  o.shard_index = shard.index;
  o.shard_count = shard.count;
  o.models = SplitList(a.models);
  o.command_line = CommandLine();
  o.Check();

  const fs::path out = a.output;
  std::vector<fs::path> inputs;
  std::error_code ec;
  if (fs::exists(o.scene, ec)) inputs.emplace_back(o.scene);
  PrepareOutputDir(out, "-o");
  CheckOutputs(out, inputs);
  experiments::RunSweep(o, out, std::cout);
  return 0;
}

int RunMerge(const MergeArgs& a) {
  const std::vector<fs::path> dirs = experiments::ShardDirs(a.dirs, experiments::SweepShardFiles());
  const fs::path out = a.output;
  std::vector<fs::path> inputs;
  for (const fs::path& d : dirs) {
    for (const char* name : kOutputs) inputs.push_back(d / name);
  }
  PrepareOutputDir(out, "-o");
  CheckOutputs(out, inputs);
  experiments::MergeSweeps(dirs, out, CommandLine(), std::cout);
  return 0;
}

}  // namespace

void AddSweepCommand(CLI::App& app, std::function<int()>& run) {
  auto a = std::make_shared<SweepArgs>();
  auto m = std::make_shared<MergeArgs>();
  std::string factor_help = "NAME=start:stop:count (or NAME=value), once or twice. Factors:";
  for (const experiments::FactorInfo& f : experiments::SweepFactors()) {
    factor_help += fmt::format("\n  {} ({}): {}", f.name, f.alias, f.meaning);
  }
  CLI::App* cmd = app.add_subcommand(
      "sweep",
      "Stability sweep: vary one or two scene factors over a grid; render, photograph (synthetic camera) and "
      "analyse each point; failure maps per method. `sweep merge` joins shards");
  cmd->add_option("--factor", a->factors, factor_help);
  cmd->add_option("--method", a->method, "exact|none|strips|warp|mesh, a comma list, or all")
      ->capture_default_str();
  cmd->add_option("--scene", a->options.scene, experiments::SceneOptionHelp())
      ->capture_default_str();
  cmd->add_option("--scale", a->options.camera_scale,
                  "Camera imager scale (0 < s <= 1; 0.25: 1500 x 1000 px for the default)")
      ->capture_default_str();
  cmd->add_option("--jobs,-j", a->options.jobs, "Worker threads over the points")->capture_default_str();
  cmd->add_option("--shard", a->shard, "Run only shard i of n (points k with k mod n = i - 1)")
      ->capture_default_str();
  cmd->add_option("--seed", a->options.seed, "Noise seed of point 0 (point k uses seed + k)")
      ->capture_default_str();
  cmd->add_option("--models", a->models, "Screen models to fit, comma-separated")->capture_default_str();
  cmd->add_option("--cols", a->options.cols, "Checkerboard squares across")->capture_default_str();
  cmd->add_option("--rows", a->options.rows, "Checkerboard squares down")->capture_default_str();
  cmd->add_option("--tolerance", a->options.tolerance_display_px, "Verification tolerance, display px (p95)")
      ->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  CLI::App* merge =
      cmd->add_subcommand("merge", "Merge sweep shards (folders, or one folder holding them) into one");
  merge->add_option("dirs", m->dirs, "Shard output folders, or a folder whose subfolders are shards")
      ->required();
  merge->add_option("-o,--output", m->output, "Output folder of the merged sweep")->required();
  merge->callback([&run, m] { run = [m] { return RunMerge(*m); }; });
  cmd->callback([&run, a, merge] {
    if (!merge->parsed()) run = [a] { return RunSweep(*a); };
  });
}

}  // namespace curvecheck::app
