#pragma once

namespace curvecheck::app {

// Parses the command line and runs the subcommand. Exit codes: 0 success, 1 failure (one line on stderr
// naming the file or option and the problem), 2 bad usage.
int Main(int argc, char** argv);

}  // namespace curvecheck::app
