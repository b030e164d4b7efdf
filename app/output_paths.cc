#include "app/output_paths.h"

#include <fmt/format.h>

#include <fstream>

#include "core/error.h"

namespace curvecheck::app {
namespace fs = std::filesystem;

void CheckNotAnInput(const fs::path& output, const std::vector<fs::path>& inputs) {
  std::error_code ec;
  for (const fs::path& in : inputs) {
    if (fs::exists(in, ec) && fs::exists(output, ec) && fs::equivalent(in, output, ec)) {
      throw Error(output.string(), "is an input of this command", "choose another output path");
    }
  }
}

void PrepareOutputDir(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw Error(option, fmt::format("'{}' exists and is not a folder", dir.string()), "give a folder path");
  }
  fs::create_directories(dir, ec);
  if (ec) throw Error(option, fmt::format("cannot create folder '{}': {}", dir.string(), ec.message()), "");
  const fs::path probe = dir / ".curvecheck-write-probe";
  {
    std::ofstream f(probe);
    if (!f || !(f << "probe") || !f.flush()) {
      throw Error(option, fmt::format("folder '{}' is not writable", dir.string()),
                  "choose a folder you can write to");
    }
  }
  fs::remove(probe, ec);
}

}  // namespace curvecheck::app
