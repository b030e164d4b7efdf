#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `bench fit` on the `bench` subcommand: speed of the screen fit per model (one photo; ten photos of
// ~500 features) and the radius statistics over many seeds (bias, scatter vs Cramer-Rao bound, coverage).
void AddBenchFitCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
