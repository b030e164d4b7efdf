#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `sweep` (issue 7 items 3-4): stability sweeps over one or two scene factors, every grid point rendered,
// photographed by the synthetic camera and analysed; sharding (`--shard i/n`) and `sweep merge`.
void AddSweepCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
