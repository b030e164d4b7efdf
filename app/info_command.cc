// `curvecheck info`: a monitor's derived geometry and its viewing from a viewpoint (core/viewing.h).
#include <fmt/format.h>

#include <iostream>

#include "app/commands.h"
#include "core/viewing.h"
#include "datasets/monitor_presets.h"

namespace curvecheck::app {

int RunInfo(const InfoOptions& o) {
  if (o.list_presets) {
    for (const std::string& name : MonitorPresetNames()) {
      const Monitor m = LoadMonitor(name);
      std::cout << fmt::format("{:<24} {}{}\n", name, m.name, name == kDefaultMonitorPreset ? "  (default)" : "");
    }
    return 0;
  }
  const Monitor m = LoadMonitor(o.monitor);
  const std::optional<Eigen::Vector3d> viewpoint =
      ViewpointFromOptions(m, o.viewpoint.value_or(""), o.distance_mm, o.offset_mm);
  if (o.json) {
    std::cout << MonitorInfoJson(m, viewpoint).dump(2) << "\n";
  } else {
    std::cout << MonitorInfoText(m, viewpoint);
  }
  return 0;
}

}  // namespace curvecheck::app
