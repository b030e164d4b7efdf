#pragma once

#include <string>
#include <vector>

namespace curvecheck::app {

// Parses the command line and runs the subcommand. Exit codes: 0 success, 1 failure (one line on stderr
// naming the file or option and the problem), 2 bad usage.
int Main(int argc, char** argv);

// The command line Main was given ("curvecheck analyze ..."), for provenance in outputs.
const std::string& CommandLine();

// The non-empty parts of a list option ("flat,cylinder" -> {"flat", "cylinder"}; "a,,b" -> {"a", "b"}).
std::vector<std::string> SplitList(const std::string& text, char separator = ',');

}  // namespace curvecheck::app
