// `curvecheck export-mpcdi` (issue 19 part 3) once its options are parsed: the correction for a measured
// (result.json: the fitted radius, and the deviation field of cylinder+deviation) or a specified monitor as a
// VESA MPCDI v2.0 file, profile 2d (mpcdi/mpcdi_file.h; README "MPCDI export"). Errors name the option at fault;
// a fit without a radius to correct for is refused with the fit's own reason.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

namespace curvecheck {

struct MpcdiExportRequest {
  std::optional<std::string> result;   // result.json of `curvecheck analyze` (excludes monitor)
  std::optional<std::string> monitor;  // or a monitor preset or spec file
  std::optional<double> radius_mm;     // with monitor: correct for this radius instead of the nominal
  // The viewpoint in the (nominal) monitor's screen frame, as for render: "x,y,z", or a distance from the screen
  // centre with an optional offset "X,Y" (core/viewing.h ViewpointFromOptions).
  std::string viewpoint;
  std::optional<double> distance_mm;
  std::optional<std::string> offset_mm;
  std::optional<std::string> grid;  // "across,down" samples; default: warp_grid.h DefaultWarpGridSize
  std::string output;               // the .mpcdi file
};

// Writes request.output and prints the source, the viewpoint, the grid's interpolation error and the alpha map's
// coverage on `log`. Throws Error.
void ExportMpcdi(const MpcdiExportRequest& request, std::ostream& log);

}  // namespace curvecheck
