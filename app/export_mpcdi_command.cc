// `curvecheck export-mpcdi`: the measured correction as a VESA MPCDI v2.0 file, profile 2d (issue 19 part 3). The
// work is analysis/mpcdi_export.h; this file parses the options.
#include "app/export_mpcdi_command.h"

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "analysis/mpcdi_export.h"
#include "app/render_options.h"
#include "core/error.h"
#include "mpcdi/warp_grid.h"

namespace curvecheck::app {

void AddExportMpcdiCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<MpcdiExportRequest>();
  CLI::App* cmd = app.add_subcommand(
      "export-mpcdi",
      "Write the correction for a measured (--result) or specified (--monitor) monitor as a VESA MPCDI v2.0 file, "
      "profile 2d: a geometry warp from each display position to the image `render --method none` draws "
      "(README \"MPCDI export\")");
  CLI::Option* result = cmd->add_option("--result", args->result,
                                        "result.json of `curvecheck analyze`: the fitted radius (and deviation field)");
  CLI::Option* monitor =
      cmd->add_option("--monitor,-m", args->monitor, "Monitor preset name, 'default', or a YAML/JSON spec file");
  result->excludes(monitor);
  cmd->add_option("--radius-mm", args->radius_mm, "With --monitor: correct for this radius instead of the nominal")
      ->needs(monitor);
  CLI::Option* viewpoint = cmd->add_option(
      "--viewpoint,-v", args->viewpoint,
      "Viewpoint x,y,z in mm in the (nominal) monitor's screen frame, as for render (or give --distance-mm)");
  AddDistanceOptions(*cmd, viewpoint, args->distance_mm, args->offset_mm);
  cmd->add_option("--grid", args->grid,
                  fmt::format("Warp samples across,down, edge to edge (default: one per {} display px, plus one)",
                              kDefaultGridSpacingPx));
  cmd->add_option("-o,--output", args->output, "Output .mpcdi file")->required();
  cmd->callback([&run, args] {
    run = [args] {
      if (!args->result && !args->monitor) {
        throw Error("export-mpcdi", "neither --result nor --monitor given",
                    "give --result result.json (the measured monitor) or --monitor M");
      }
      ExportMpcdi(*args, std::cout);
      return 0;
    };
  });
}

}  // namespace curvecheck::app
