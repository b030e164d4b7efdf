#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `bench models` on the `bench` subcommand: every screen model fitted alone to synthetic observations
// of several true screens (cylinder, 8% off-nominal radius, 1 deg lean, 2 mm bulge): fit time against radius
// error and against surface (deviation) error; CSV, chart with the Pareto fronts, terminal table.
void AddBenchModelsCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
