// One function per subcommand. Each returns the process exit code (0 success, 1 failure) and throws
// curvecheck::Error for failures that main() reports as one line.
#pragma once

#include <optional>
#include <string>

namespace curvecheck::app {

struct InfoOptions {
  std::string monitor = "default";  // preset name, "default", or YAML/JSON file
  std::optional<std::string> viewpoint;  // "x,y,z" in mm, screen frame
  std::optional<double> distance_mm;     // or the viewpoint from the screen centre (render_options.h)
  std::optional<std::string> offset_mm;
  bool json = false;                 // machine-readable output
  bool list_presets = false;
};
int RunInfo(const InfoOptions& options);

struct DemoOptions {
  std::string output_dir = "curvecheck-demo";  // where the demo writes its outputs
};
int RunDemo(const DemoOptions& options);

}  // namespace curvecheck::app
