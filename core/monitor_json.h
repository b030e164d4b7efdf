// The monitor object of the JSON file contracts (architecture.md, pattern.json "monitor").
#pragma once

#include <nlohmann/json.hpp>

#include "core/monitor.h"

namespace curvecheck {

// { "name", "resolution": [Nx, Ny], "width_mm", "height_mm", "radius_mm": R or "flat",
//   derived: "pixel_pitch_mm", "half_sector_deg", "chord_width_mm", "sagitta_mm" }.
// Numbers are written with full double precision.
nlohmann::json MonitorToJson(const Monitor& m);

}  // namespace curvecheck
