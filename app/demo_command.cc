// `curvecheck demo`: the embedded default end to end (experiments/demo.h).
#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <memory>

#include "app/commands.h"
#include "core/output_paths.h"
#include "experiments/demo.h"

namespace curvecheck::app {

int RunDemo(const DemoOptions& o) {
  const std::filesystem::path out = o.output_dir;
  PrepareOutputDir(out, "--output");
  PrepareOutputDir(out / "analysis", "--output");
  return experiments::RunDemo(out, std::cout) ? 0 : 1;
}

void AddDemoCommand(CLI::App& app, std::function<int()>& run) {
  auto demo = std::make_shared<DemoOptions>();
  CLI::App* cmd = app.add_subcommand(
      "demo", "Run the pipeline on the embedded default: render a corrected checkerboard, photograph it with the "
              "synthetic camera (49\" 1000R monitor, 24 MP camera 1.5 m in front), analyse the photo");
  cmd->add_option("-o,--output", demo->output_dir, "Output folder")->capture_default_str();
  cmd->callback([&run, demo] { run = [demo] { return RunDemo(*demo); }; });
}

}  // namespace curvecheck::app
