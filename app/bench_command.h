#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `curvecheck bench` (with `bench render`) on the app.
void AddBenchCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
