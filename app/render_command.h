#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace curvecheck::app {

// Registers `curvecheck render` on the app; sets `run` when the subcommand is chosen.
void AddRenderCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
