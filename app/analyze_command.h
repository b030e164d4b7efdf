#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `analyze`: detect, verify the correction, fit the screen model, write result.json and overlays.
void AddAnalyzeCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
