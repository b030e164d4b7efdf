#include "datasets/dataset_files.h"

#include <string_view>
#include <utility>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace internal {
const std::vector<std::pair<std::string_view, std::string_view>>& EmbeddedDatasetFiles();
}  // namespace internal

std::vector<std::string> DatasetFileNames() {
  std::vector<std::string> names;
  for (const auto& [name, text] : internal::EmbeddedDatasetFiles()) names.emplace_back(name);
  return names;
}

std::string DatasetFileText(const std::string& relative_path) {
  for (const auto& [name, text] : internal::EmbeddedDatasetFiles()) {
    if (name == relative_path) return std::string(text);
  }
  throw Error(relative_path, "is not an embedded dataset file", "");
}

std::filesystem::path WriteDatasetFiles(const std::filesystem::path& dir) {
  for (const auto& [name, text] : internal::EmbeddedDatasetFiles()) {
    const std::filesystem::path path = dir / std::string(name);
    std::error_code ec;
    if (std::filesystem::exists(path, ec)) {
      if (ReadFileToString(path) == text) continue;
      throw Error(path.string(), "exists with other content than the embedded dataset file",
                  "remove it or choose another output folder");
    }
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) throw Error(path.parent_path().string(), "cannot create the folder: " + ec.message(), "");
    WriteFileAtomic(path, text);
  }
  return dir;
}

}  // namespace curvecheck
