// One function per subcommand. Each returns the process exit code (0 success, 1 failure) and throws
// curvecheck::Error for failures that main() reports as one line.
#pragma once

#include <functional>
#include <optional>
#include <string>

namespace CLI {
class App;
}

namespace curvecheck::app {

// Every subcommand of `curvecheck` (app/all_commands.cc): the Program::add_commands of app/main.cc.
void AddAllCommands(CLI::App& app, std::function<int()>& run);

struct InfoOptions {
  std::string monitor = "default";  // preset name, "default", or YAML/JSON file
  std::optional<std::string> viewpoint;  // "x,y,z" in mm, screen frame
  std::optional<double> distance_mm;     // or the viewpoint from the screen centre (render_options.h)
  std::optional<std::string> offset_mm;
  bool json = false;                 // machine-readable output
  bool list_presets = false;
};
int RunInfo(const InfoOptions& options);
// Registers `info` on the app; sets `run` when it is chosen (app/info_command.cc).
void AddInfoCommand(CLI::App& app, std::function<int()>& run);

struct DemoOptions {
  std::string output_dir = "curvecheck-demo";  // where the demo writes its outputs
};
int RunDemo(const DemoOptions& options);
// Registers `demo` on the app; sets `run` when it is chosen. Alone, it is the demo-only program's one
// subcommand (app/demo_main.cc).
void AddDemoCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
