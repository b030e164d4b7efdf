#include "core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace curvecheck {
namespace {

TEST(ParallelFor, RunsEveryIndexOnceInAnyBlockSize) {
  for (const int block : {1, 3, 4, 100}) {
    std::vector<std::atomic<int>> hits(37);
    ParallelFor(37, [&](int i) { ++hits[static_cast<size_t>(i)]; }, block);
    for (size_t i = 0; i < hits.size(); ++i) EXPECT_EQ(hits[i].load(), 1) << "index " << i << ", block " << block;
  }
  int calls = 0;
  ParallelFor(0, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ParallelFor, RethrowsAFailureOnTheCallingThreadAfterEveryThreadStopped) {
  std::atomic<int> running{0}, after_return{0};
  std::string message;
  try {
    ParallelFor(1000, [&](int i) {
      ++running;
      if (i == 5 || i == 500) {
        --running;
        throw std::runtime_error(i == 5 ? "piece 5 failed" : "piece 500 failed");
      }
      --running;
    });
  } catch (const std::runtime_error& e) {
    message = e.what();
    after_return = running.load();
  }
  EXPECT_TRUE(message == "piece 5 failed" || message == "piece 500 failed") << message;
  EXPECT_EQ(after_return.load(), 0);  // no body still running when the failure reaches the caller
}

}  // namespace
}  // namespace curvecheck
