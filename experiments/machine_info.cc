#include "experiments/machine_info.h"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "core/error.h"

namespace curvecheck::experiments {

std::string DescribeMachine() {
  std::string cpu = "unknown CPU";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  }
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  return fmt::format("{}, {} cores, build {}, {:%Y-%m-%d %H:%M} UTC", cpu, std::thread::hardware_concurrency(),
                     CURVECHECK_BUILD_TYPE, fmt::gmtime(now));
}

void CheckCount(int64_t value, int64_t lo, int64_t hi, const char* option) {
  if (value < lo || value > hi) {
    throw Error(option, fmt::format("{} is out of range", value), fmt::format("use {}..{}", lo, hi));
  }
}

}  // namespace curvecheck::experiments
