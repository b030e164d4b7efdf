#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `export-mpcdi`: the correction for a measured (result.json) or specified monitor as a VESA MPCDI v2.0 2d
// file (mpcdi/mpcdi_file.h; README "MPCDI export").
void AddExportMpcdiCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
