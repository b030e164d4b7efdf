#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `analyze` to the `bench` subcommand: the whole analysis on synthetic photos over many noise seeds.
void AddBenchAnalyzeCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
