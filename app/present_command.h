// `curvecheck present`: shows PNG patterns fullscreen on one output, pixel for pixel (render/presenter.h).
// Kept apart from app/commands.h so that `render --present` can forward here: build a PresenterOptions and call
// RunPresent.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

#include "render/presenter.h"

namespace curvecheck::app {

// Checks the options, runs the presenter with "shown k/n path" lines on stdout; returns the exit code (0).
// Throws curvecheck::Error (exit 1 in Main).
int RunPresent(const PresenterOptions& options);

// Adds the `present` subcommand to `app`; when it is chosen on the command line, sets `run` to run it.
void AddPresentCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
