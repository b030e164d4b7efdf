#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `report`: the HTML page of a result.json (analysis/report.h), with the overlay images beside it.
void AddReportCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
