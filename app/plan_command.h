#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `plan`: the capture plan (analysis/plan.h): predicted radius sigma and verification capability,
// recommended camera positions and number of photos; plan.json and a chart.
void AddPlanCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
