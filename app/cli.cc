#include "app/cli.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <functional>
#include <iostream>
#include <string>

#include "app/analyze_command.h"
#include "app/bench_command.h"
#include "app/calibrate_command.h"
#include "app/capture_command.h"
#include "app/capture_synth_command.h"
#include "app/commands.h"
#include "app/export_mpcdi_command.h"
#include "app/plan_command.h"
#include "app/present_command.h"
#include "app/render_command.h"
#include "app/render_options.h"
#include "app/report_command.h"
#include "app/sweep_command.h"
#include "app/thirdparty_commands.h"
#include "core/decimal.h"
#include "core/error.h"

#ifndef CURVECHECK_VERSION
#define CURVECHECK_VERSION "unknown"
#endif

namespace curvecheck::app {
namespace {

// One exit code for every error (cli.h): a value CLI11 cannot convert and one our checks refuse are the same
// mistake to the user, and only where the check runs told them apart.
constexpr int kExitFailure = 1;

// Every numeric option of `app` and its subcommands reads decimal text only (core/decimal.h), through a
// transform that runs before the option's other checks and CLI11's conversion: CLI11 alone reads "0x10" as 16,
// "010" as 8 (an integer's base is taken from its prefix) and "" as 0. A refusal throws Error naming the option,
// what is wrong and an example (the option's default where it has one).
void RequireDecimalNumbers(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    const std::string type = option->get_type_name();
    const bool whole = type == "INT" || type == "UINT";
    if (!whole && type != "FLOAT") continue;
    const std::string name = option->get_name();
    const std::string fallback = whole ? "2" : "0.5";
    const std::string default_text = option->get_default_str();
    const std::string example =
        !default_text.empty() && DecimalProblem(default_text, whole).empty() ? default_text : fallback;
    option->transform(CLI::Validator(
        [name, whole, example](std::string& text) {
          const std::string problem = DecimalProblem(text, whole);
          if (!problem.empty()) {
            throw Error(name, problem,
                        fmt::format("give a {} such as {}", whole ? "whole number" : "decimal number", example));
          }
          // Canonical digits: CLI11 would read "010" as octal.
          if (whole) text = std::to_string(*ParseWholeNumber(text));
          return std::string();
        },
        "", "decimal"));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) RequireDecimalNumbers(*sub);
}

// The subcommand a failed parse was in, as typed after "curvecheck" ("sweep merge"; "" for the top level).
std::string FailedCommand(const CLI::App& app) {
  std::string path;
  const CLI::App* at = &app;
  for (;;) {
    const std::vector<CLI::App*> subs = at->get_subcommands();
    if (subs.empty()) return path;
    at = subs.back();
    path += (path.empty() ? "" : " ") + at->get_name();
  }
}

// A CLI11 parse error as the one line every error is: "WHERE: problem; see 'curvecheck SUB --help'". WHERE is
// the option when CLI11's message starts with it ("--output is required"), else the subcommand.
std::string UsageLine(const CLI::App& app, const CLI::ParseError& e, const std::string& first_word) {
  const std::string command = FailedCommand(app);
  // CLI11 says "A subcommand is required" for a misspelt one.
  if (command.empty() && !first_word.empty() && first_word[0] != '-') {
    return fmt::format("{}: is not a subcommand; see 'curvecheck --help' for the list", first_word);
  }
  const std::string help = command.empty() ? "curvecheck --help" : "curvecheck " + command + " --help";
  std::string message = e.what();
  std::string where = command.empty() ? "curvecheck" : command;
  if (message.rfind("-", 0) == 0) {
    const size_t end = message.find_first_of(": ");
    where = message.substr(0, end);
    message = message.substr(std::min(message.size(), message.find_first_not_of(": ", end)));
  }
  if (message.size() > 1 && std::isupper(static_cast<unsigned char>(message[0])) &&
      !std::isupper(static_cast<unsigned char>(message[1]))) {
    message[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(message[0])));
  }
  return fmt::format("{}: {}; see '{}'", where, message, help);
}

}  // namespace

static std::string& CommandLineStorage() {
  static std::string line;
  return line;
}

const std::string& CommandLine() { return CommandLineStorage(); }

CLI::Validator InRange(double lo, double hi, const std::string& unit, const std::string& why) {
  return CLI::Validator(
      [=](std::string& text) {
        const std::optional<double> v = ParseDecimal(text);  // RequireDecimalNumbers refused anything else
        if (v && *v >= lo && *v <= hi) return std::string();
        return fmt::format("{} is outside {}..{}{}{} ({})", text, lo, hi, unit.empty() ? "" : " ", unit, why);
      },
      "", "in range");
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
  // `plan` (issue 20 part 1): the capture plan; app/plan_command.cc.
  AddPlanCommand(app, run);
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
  // `export-mpcdi` (issue 19 part 3): app/export_mpcdi_command.cc.
  AddExportMpcdiCommand(app, run);
  // `pattern` and `check-screenshot` (issue 19): app/pattern_command.cc, app/check_screenshot_command.cc.
  AddPatternCommand(app, run);
  AddCheckScreenshotCommand(app, run);

  // `curvecheck --version`: the version the report page records (PROJECT_VERSION of CMakeLists.txt).
  app.set_version_flag("--version", std::string("curvecheck ") + CURVECHECK_VERSION, "Print the version and exit");
  RequireDecimalNumbers(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "curvecheck: error: " << UsageLine(app, e, argc > 1 ? argv[1] : "") << "\n";
    return kExitFailure;
  } catch (const Error& e) {  // a value refused while parsing (RequireDecimalNumbers)
    std::cerr << "curvecheck: error: " << e.what() << "\n";
    return kExitFailure;
  }

  try {
    if (!run) throw Error(FailedCommand(app), "nothing to run", "see 'curvecheck --help'");
    return run();
  } catch (const Error& e) {
    std::cerr << "curvecheck: error: " << e.what() << "\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "curvecheck: internal error: " << e.what() << "; please report it with the command line\n";
    return kExitFailure;
  }
}

}  // namespace curvecheck::app
