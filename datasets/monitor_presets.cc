#include "datasets/monitor_presets.h"

#include <filesystem>

#include "core/config.h"
#include "core/error.h"
#include "core/path_check.h"

namespace curvecheck {
namespace internal {
const std::vector<std::pair<std::string_view, std::string_view>>& EmbeddedMonitorPresets();
}  // namespace internal

std::vector<std::string> MonitorPresetNames() {
  std::vector<std::string> names;
  for (const auto& [name, text] : internal::EmbeddedMonitorPresets()) names.emplace_back(name);
  return names;
}

std::string MonitorPresetText(const std::string& name) {
  for (const auto& [n, text] : internal::EmbeddedMonitorPresets()) {
    if (n == name) return std::string(text);
  }
  return "";
}

Monitor LoadMonitor(const std::string& spec) {
  const PathKind kind = ClassifyPath(spec);
  if (kind == PathKind::kLinkLoop) RequireFile(spec);  // a loop is not "neither a preset nor a file"
  if (kind != PathKind::kMissing && kind != PathKind::kUnreachable) return MonitorFromConfig(ConfigMap::Load(spec));
  const std::string name = spec == "default" ? kDefaultMonitorPreset : spec;
  const std::string text = MonitorPresetText(name);
  if (text.empty()) {
    std::string list;
    for (const std::string& n : MonitorPresetNames()) list += (list.empty() ? "" : ", ") + n;
    throw Error(spec, "is neither a monitor preset nor an existing file",
                "give a YAML file or one of: default, " + list);
  }
  return MonitorFromConfig(ConfigMap::Parse(text, "preset '" + name + "'"));
}

}  // namespace curvecheck
