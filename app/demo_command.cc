// `curvecheck demo`: the embedded default end to end (experiments/demo.h).
#include <filesystem>
#include <iostream>

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

}  // namespace curvecheck::app
