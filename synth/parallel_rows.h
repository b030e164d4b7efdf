// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// Row-parallel loops for the ray table, the tracer and the sensor.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace curvecheck::synth_internal {

// Threads ParallelRows uses: all cores.
inline int ThreadCount() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

// body(y) for y in [0, rows) on all cores; rows are handed out in blocks of 4 as threads free up (rows that
// see only the room are cheaper than rows across the display). The first exception a body throws is rethrown
// here, after every thread has stopped; the other threads stop early.
template <typename F>
void ParallelRows(int rows, const F& body) {
  const int threads = ThreadCount();
  std::atomic<int> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto work = [&] {
    try {
      for (int y0 = next.fetch_add(4); y0 < rows; y0 = next.fetch_add(4)) {
        for (int y = y0; y < std::min(rows, y0 + 4); ++y) body(y);
      }
    } catch (...) {  // the first failure is rethrown on the calling thread; the others stop early
      next = rows;
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace curvecheck::synth_internal
