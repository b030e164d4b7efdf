// The one wall-clock stopwatch (steady clock; not affected by clock changes). Starts when constructed.
#pragma once

#include <chrono>

namespace curvecheck {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void Restart() { start_ = std::chrono::steady_clock::now(); }
  double Seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  double Ms() const { return 1e3 * Seconds(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace curvecheck
