#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// `curvecheck calibrate`: camera intrinsics from chessboard photos (calibrate/calibrate.h).
void AddCalibrateCommand(CLI::App& app, std::function<int()>& run);

}  // namespace curvecheck::app
