#include "app/cli.h"

#include <CLI/CLI.hpp>
#include <exception>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>

#include "app/analyze_command.h"
#include "app/bench_command.h"
#include "app/calibrate_command.h"
#include "app/capture_command.h"
#include "app/capture_synth_command.h"
#include "app/commands.h"
#include "app/present_command.h"
#include "app/render_command.h"
#include "app/render_options.h"
#include "app/report_command.h"
#include "app/sweep_command.h"
#include "core/error.h"

namespace curvecheck::app {
namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

}  // namespace

static std::string& CommandLineStorage() {
  static std::string line;
  return line;
}

const std::string& CommandLine() { return CommandLineStorage(); }

std::vector<std::string> SplitList(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::stringstream parts(text);
  for (std::string p; std::getline(parts, p, separator);) {
    if (!p.empty()) out.push_back(p);
  }
  return out;
}

int Main(int argc, char** argv) {
  for (int i = 0; i < argc; ++i) CommandLineStorage() += (i ? " " : "") + std::string(i ? argv[i] : "curvecheck");
  CLI::App app{"curvecheck: photogrammetric validation of curved (and flat) monitors", "curvecheck"};
  app.require_subcommand(1);
  app.fallthrough(false);

  std::function<int()> run;

  InfoOptions info;
  CLI::App* info_cmd = app.add_subcommand(
      "info", "Print a monitor's derived geometry and, from a viewpoint, its fields of view and pixel density");
  info_cmd->add_option("--monitor,-m", info.monitor, "Monitor preset name, 'default', or a YAML/JSON spec file")
      ->capture_default_str();
  CLI::Option* info_viewpoint = info_cmd->add_option(
      "--viewpoint,-v", info.viewpoint,
      "Viewpoint x,y,z in mm in the screen frame (origin on the cylinder axis; the screen centre is at 0,0,-R; for a "
      "flat monitor the screen is z = 0; or give --distance-mm)");
  AddDistanceOptions(*info_cmd, info_viewpoint, info.distance_mm, info.offset_mm);
  info_cmd->add_flag("--json", info.json, "Print JSON instead of text");
  info_cmd->add_flag("--list-presets", info.list_presets, "List the monitor presets and exit");
  info_cmd->callback([&] { run = [&] { return RunInfo(info); }; });

  DemoOptions demo;
  CLI::App* demo_cmd = app.add_subcommand(
      "demo", "Run the pipeline on the embedded default: render a corrected checkerboard, photograph it with the "
              "synthetic camera (49\" 1000R monitor, 24 MP camera 1.5 m in front), analyse the photo");
  demo_cmd->add_option("-o,--output", demo.output_dir, "Output folder")->capture_default_str();
  demo_cmd->callback([&] { run = [&] { return RunDemo(demo); }; });

  AddRenderCommand(app, run);
  // `analyze` (issue 6): app/analyze_command.cc.
  AddAnalyzeCommand(app, run);
  // `report` (issue 7 item 1): the HTML page of a result.json; app/report_command.cc.
  AddReportCommand(app, run);
  AddBenchCommand(app, run);
  // `present` (issue 3 item 8): the fullscreen presenter; app/present_command.cc.
  AddPresentCommand(app, run);
  // `capture` (issue 4 item 3): webcam, DSLR, sessions, import; app/capture_command.cc.
  CLI::App* capture = AddCaptureCommand(app, run);
  AddCaptureSynthCommand(*capture, run);
  // `calibrate` (issue 5): app/calibrate_command.cc.
  AddCalibrateCommand(app, run);

  // `sweep` (issue 7 items 3-4): app/sweep_command.cc.
  AddSweepCommand(app, run);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "curvecheck: usage: " << e.what() << "; see 'curvecheck --help'\n";
    return kExitUsage;
  }

  try {
    return run ? run() : kExitUsage;
  } catch (const Error& e) {
    std::cerr << "curvecheck: error: " << e.what() << "\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "curvecheck: internal error: " << e.what() << "; please report it with the command line\n";
    return kExitFailure;
  }
}

}  // namespace curvecheck::app
