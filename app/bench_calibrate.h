#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace curvecheck::app {

// Registers `bench calibrate` on the `bench` subcommand (issue 7 item 2c): lens-model speed against accuracy. On a
// synthetic chessboard set with a known OPENCV8 lens, each lens model (OPENCV4, OPENCV8, splined at several knot
// densities) is calibrated --runs times: median calibration time against the projection error of the recovered
// model against the truth (RMS px over the imager) and the uncertainty mrcal reports. Writes calibrate_bench.csv
// and a log-log chart (Pareto front marked), prints a table with the machine.
void AddBenchCalibrateCommand(CLI::App& bench, std::function<int()>& run);

}  // namespace curvecheck::app
