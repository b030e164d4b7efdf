// flat_vs_board_bench: `curvecheck bench calibrate --flat-vs-board` (bench_flat_vs_board.h) as a small program of
// its own, linking only what the bench needs (not the whole application), for runs while the rest of the tool is
// being changed. Not a test: run by hand.
//   build/experiments/flat_vs_board_bench [--trials N] [--seed S] [--scale F] [-o DIR]
// Same options, same output (DIR/flat_vs_board_trials.csv, DIR/cache/) as the subcommand.
#include <filesystem>
#include <iostream>
#include <string>

#include "core/error.h"
#include "experiments/bench_flat_vs_board.h"

int main(int argc, char** argv) {
  curvecheck::experiments::BenchFlatVsBoardOptions o;
  std::filesystem::path out = "bench-flat-vs-board";
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (i + 1 >= argc) throw curvecheck::Error(a, "needs a value", "see the header of bench_flat_vs_board_main.cc");
      const std::string v = argv[++i];
      if (a == "--trials") {
        o.trials = std::stoi(v);
      } else if (a == "--seed") {
        o.seed = std::stoull(v);
      } else if (a == "--scale") {
        o.scale = std::stod(v);
      } else if (a == "-o") {
        out = v;
      } else {
        throw curvecheck::Error(a, "unknown option", "give --trials, --seed, --scale or -o");
      }
    }
    o.Check();
    std::filesystem::create_directories(out);
    curvecheck::experiments::RunBenchFlatVsBoard(o, out, std::cout);
  } catch (const curvecheck::Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
