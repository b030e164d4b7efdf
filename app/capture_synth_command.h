#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `synth` to the `capture` subcommand: ray-traces a photo of a scene's true monitor showing a pattern.
void AddCaptureSynthCommand(CLI::App& capture, std::function<int()>& run);

}  // namespace curvecheck::app
