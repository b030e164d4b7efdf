// `curvecheck bench render`: speed against accuracy of every correction method and setting. For each setting:
// the median render time over several runs (device set-up and uploads excluded, reported separately) and the
// mapping error against the exact mapping (MeasureMappingError). Writes a CSV, a gnuplot chart (error against
// time, log-log, Pareto front marked) and its script, and prints a table.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <ostream>

#include "core/monitor.h"
#include "pattern/pattern.h"

namespace curvecheck::experiments {

struct BenchRenderOptions {
  int runs = 5;        // timed runs per setting (median reported), after one warm-up
  bool quick = false;  // a reduced set of settings (smoke tests)

  // Throws Error naming --runs when runs is outside 1..100.
  void Check() const;
};

// Benchmarks every setting on `monitor` from `viewpoint_in_screen` with a pattern of `spec`; writes
// render_bench.csv, render_bench.png and render_bench.gp into `dir` (an existing folder) and prints the
// table, the device set-up time and the Pareto front to `log`. A setting the renderer refuses is reported and
// skipped.
void RunBenchRender(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                    const PatternSpec& spec, const BenchRenderOptions& options,
                    const std::filesystem::path& dir, std::ostream& log);

}  // namespace curvecheck::experiments
