// `curvecheck info`: a monitor's derived geometry and its viewing from a viewpoint (core/viewing.h).
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "app/commands.h"
#include "app/render_options.h"
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

void AddInfoCommand(CLI::App& app, std::function<int()>& run) {
  auto info = std::make_shared<InfoOptions>();
  CLI::App* info_cmd = app.add_subcommand(
      "info", "Print a monitor's derived geometry and, from a viewpoint, its fields of view and pixel density");
  info_cmd->add_option("--monitor,-m", info->monitor, "Monitor preset name, 'default', or a YAML/JSON spec file")
      ->capture_default_str();
  CLI::Option* info_viewpoint = info_cmd->add_option(
      "--viewpoint,-v", info->viewpoint,
      "Viewpoint x,y,z in mm in the screen frame (origin on the cylinder axis; the screen centre is at 0,0,-R; for a "
      "flat monitor the screen is z = 0; or give --distance-mm)");
  AddDistanceOptions(*info_cmd, info_viewpoint, info->distance_mm, info->offset_mm);
  info_cmd->add_flag("--json", info->json, "Print JSON instead of text");
  info_cmd->add_flag("--list-presets", info->list_presets, "List the monitor presets and exit");
  info_cmd->callback([&run, info] { run = [info] { return RunInfo(*info); }; });
}

}  // namespace curvecheck::app
