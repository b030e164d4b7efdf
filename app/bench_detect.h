#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `curvecheck bench detect` on the `bench` subcommand (app/bench_command.cc).
void AddBenchDetectCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
