// Monitor presets: the YAML files of datasets/monitors/, embedded at build time.
#pragma once

#include <string>
#include <vector>

#include "core/monitor.h"

namespace curvecheck {

// The preset used when none is given: 49" 32:9 5120x1440 1000R.
inline constexpr const char* kDefaultMonitorPreset = "49in-5120x1440-1000r";

// Names of the embedded presets (file stems), sorted.
std::vector<std::string> MonitorPresetNames();

// The YAML text of a preset, or "" if there is none by that name.
std::string MonitorPresetText(const std::string& name);

// `spec` is a preset name, "default", or a path to a YAML/JSON file. A path that exists wins over a preset
// of the same name. Throws Error naming the spec if it is neither, listing the presets.
Monitor LoadMonitor(const std::string& spec);

}  // namespace curvecheck
