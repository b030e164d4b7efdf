// A parallel loop over all cores for independent pieces of work (rows of an image, candidate models of a fit).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace curvecheck {

// Threads ParallelFor uses: all cores.
inline int ThreadCount() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

// body(i) for i in [0, count) on all cores (at most max_threads when > 0); indices are handed out in blocks of
// `block` as threads free up (so uneven pieces balance). The first exception a body throws is rethrown here, after
// every thread has stopped; the other threads stop early. The bodies must not share mutable state.
template <typename F>
void ParallelFor(int count, const F& body, int block = 1, int max_threads = 0) {
  const int cores = max_threads > 0 ? std::min(max_threads, ThreadCount()) : ThreadCount();
  const int threads = std::min(cores, std::max(1, (count + block - 1) / block));
  std::atomic<int> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto work = [&] {
    try {
      for (int i0 = next.fetch_add(block); i0 < count; i0 = next.fetch_add(block)) {
        for (int i = i0; i < std::min(count, i0 + block); ++i) body(i);
      }
    } catch (...) {  // the first failure is rethrown on the calling thread; the others stop early
      next = count;
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

}  // namespace curvecheck
