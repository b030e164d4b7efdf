// A one-line description of the machine and build, for benchmark outputs.
#pragma once

#include <string>

namespace curvecheck::experiments {

// "CPU model, N cores, build type, date".
std::string DescribeMachine();

}  // namespace curvecheck::experiments
