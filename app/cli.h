#pragma once

#include <functional>
#include <string>

// Declared only: a program's main() includes this header, and CLI11's (10 s of compile time) only where options
// are declared (issue 18).
namespace CLI {
class App;
class Validator;
}  // namespace CLI

namespace curvecheck::app {

// A command-line program: its name (in usage lines, errors and --version), its --help description, and what
// registers its subcommands (each sets `run` to its work when chosen). `curvecheck` (app/main.cc) has every
// subcommand; `curvecheck-demo` (app/demo_main.cc) only `demo`, so that a first run builds only what the demo
// needs.
struct Program {
  std::string name;
  std::string description;
  std::function<void(CLI::App& app, std::function<int()>& run)> add_commands;
};

// Parses the command line and runs the subcommand. Exit codes, one rule: 0 when the command did its work (a
// failed or inconclusive verification, an all-failing sweep: results, not errors); 1 for every error, whether
// the command line is wrong (an unknown option, a missing one, a value that is not a decimal number or is out of
// its range) or the work failed (a file, the device); `bench analyze` and `demo` also exit 1 when their
// acceptance criterion is not met. An error is one line on stderr, "curvecheck: error: WHERE: problem; fix",
// WHERE the option, file or subcommand; a usage error's fix is "see 'curvecheck SUBCOMMAND --help'". Numeric
// options take decimal text only (core/decimal.h). `curvecheck --version` prints the version. "curvecheck" stands
// for program.name throughout.
int Main(int argc, char** argv, const Program& program);

// The command line Main was given ("curvecheck analyze ..."), for provenance in outputs.
const std::string& CommandLine();

// A check for a numeric option: its value must lie in [lo, hi] (`unit` after the bounds: "ms", "px", ""), with
// `why` saying what the bounds stand for. Refused as "--opt: 0 is outside 1..86400000 ms (WHY); see 'curvecheck
// SUB --help'". Use it instead of CLI::PositiveNumber / NonNegativeNumber, which print their bound, the largest
// double, with 309 digits (CLI11 2.1.2).
CLI::Validator InRange(double lo, double hi, const std::string& unit, const std::string& why);

}  // namespace curvecheck::app
