#pragma once

#include <string>

namespace curvecheck::app {

// Parses the command line and runs the subcommand. Exit codes: 0 success, 1 failure (one line on stderr
// naming the file or option and the problem), 2 bad usage.
int Main(int argc, char** argv);

// The command line Main was given ("curvecheck analyze ..."), for provenance in outputs.
const std::string& CommandLine();

}  // namespace curvecheck::app
