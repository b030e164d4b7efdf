// Commands for other applications' corrections (issue 19): `curvecheck pattern` (app/pattern_command.cc) writes the
// textured quad and the exact display positions; `curvecheck check-screenshot` (app/check_screenshot_command.cc)
// measures a framebuffer capture of the application's corrected output against them.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

void AddPatternCommand(CLI::App& app, std::function<int()>& run);
void AddCheckScreenshotCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
