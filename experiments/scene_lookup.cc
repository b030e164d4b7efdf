#include "experiments/scene_lookup.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>

#include "core/camera_model.h"
#include "core/config.h"
#include "core/error.h"
#include "core/path_check.h"
#include "datasets/dataset_files.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

constexpr const char* kScenesDir = "scenes";

fs::path EmbeddedScenePath(const std::string& name) { return fs::path(kScenesDir) / (name + ".yaml"); }

}  // namespace

std::vector<std::string> EmbeddedSceneNames() {
  std::vector<std::string> names;
  for (const std::string& file : DatasetFileNames()) {
    const fs::path p(file);
    if (p.parent_path() == kScenesDir && p.extension() == ".yaml") names.push_back(p.stem().string());
  }
  return names;
}

std::string SceneOptionHelp() {
  return fmt::format("Scene YAML, or an embedded scene (works from any folder): {}",
                     fmt::join(EmbeddedSceneNames(), ", "));
}

bool IsEmbeddedScene(const std::string& name) {
  const std::vector<std::string> names = EmbeddedSceneNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

SyntheticScene LoadEmbeddedScene(const std::string& name, const std::string& option) {
  if (!IsEmbeddedScene(name)) {
    throw Error(option, fmt::format("'{}' is not an embedded scene", name),
                fmt::format("give one of: {}", fmt::join(EmbeddedSceneNames(), ", ")));
  }
  const std::string scene_file = EmbeddedScenePath(name).string();
  const ConfigMap config = ConfigMap::Parse(DatasetFileText(scene_file), "embedded " + scene_file);
  // The camera model path is relative to the scene's folder, as for a scene file (../cameras/x.cameramodel).
  return SceneFromConfig(config, [](const std::string& model) {
    const std::string camera_file = (fs::path(kScenesDir) / model).lexically_normal().generic_string();
    return ParseCameraModel(DatasetFileText(camera_file), "embedded " + camera_file);
  });
}

SyntheticScene FindScene(const std::string& name_or_path, const std::string& option) {
  const PathKind kind = ClassifyPath(name_or_path);
  if (kind == PathKind::kLinkLoop) RequireFile(name_or_path);  // a loop is not "neither a file nor a scene"
  if (kind != PathKind::kMissing && kind != PathKind::kUnreachable) return LoadScene(name_or_path);
  if (!IsEmbeddedScene(name_or_path)) {
    throw Error(option, fmt::format("'{}' is neither a file nor an embedded scene", name_or_path),
                fmt::format("give a scene YAML, or an embedded scene: {}", fmt::join(EmbeddedSceneNames(), ", ")));
  }
  return LoadEmbeddedScene(name_or_path, option);
}

std::string SceneSource(const std::string& name_or_path) {
  std::error_code ec;
  return fs::exists(name_or_path, ec) ? name_or_path : "embedded scene " + name_or_path;
}

}  // namespace curvecheck::experiments
