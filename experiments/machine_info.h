// What the benches and the sweep share: the machine line of their outputs, the range check of their count options.
#pragma once

#include <cstdint>
#include <string>

namespace curvecheck::experiments {

// "CPU model, N cores, build type, date".
std::string DescribeMachine();

// Throws Error(option, "<value> is out of range", "use lo..hi") unless lo <= value <= hi.
void CheckCount(int64_t value, int64_t lo, int64_t hi, const char* option);

}  // namespace curvecheck::experiments
