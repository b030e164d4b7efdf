// `curvecheck capture`: photographs of the pattern. Subcommands here: camera (V4L2 webcam), gphoto2 (DSLR),
// session (a planned list of shots, shown with the presenter), import (a folder of existing photos). Other
// subcommands (the synthetic camera's `synth`) are added to the returned CLI::App.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Adds `capture` (which requires a subcommand) to `app` and returns it; when one of its subcommands is chosen
// on the command line, sets `run` to run it.
CLI::App* AddCaptureCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
