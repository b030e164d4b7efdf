#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>

namespace curvecheck::app {

// Registers `curvecheck bench` and its subcommands (render, capture, detect, calibrate here; fit, models and
// analyze through AddBenchAnalysisCommands) on the app.
void AddBenchCommand(CLI::App& app, std::function<int()>& run);

// Registers `bench fit`, `bench models` and `bench analyze` (app/bench_analysis_command.cc) on `bench`.
void AddBenchAnalysisCommands(CLI::App& bench, std::function<int()>& run);

// Creates the output folder `dir` of a bench; throws Error if it cannot.
void CreateBenchFolder(const std::filesystem::path& dir);

}  // namespace curvecheck::app
