#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `curvecheck bench` (with `bench render` and `bench capture`) on the app.
void AddBenchCommand(CLI::App& app, std::function<int()>& run);

// Registers `bench capture` (app/bench_capture.cc) on the `bench` subcommand.
void AddBenchCaptureCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
