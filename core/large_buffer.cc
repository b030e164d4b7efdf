#include "core/large_buffer.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace curvecheck {

void AdviseHugePages(void* data, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr size_t kMinBytes = size_t{4} << 20;
  if (data == nullptr || bytes < kMinBytes) return;
  const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + page - 1) / page * page;
  const uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) / page * page;
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // a refusal is harmless
#else
  (void)data;
  (void)bytes;
#endif
}

cv::Mat NewLargeMat(int rows, int cols, int type) {
  cv::Mat m(rows, cols, type);
  AdviseHugePages(m.data, m.total() * m.elemSize());
  return m;
}

cv::Mat ReuseOrNewLargeMat(const cv::Mat& storage, int rows, int cols, int type) {
  const size_t needed = static_cast<size_t>(rows) * static_cast<size_t>(cols) * CV_ELEM_SIZE(type);
  if (storage.isContinuous() && storage.data != nullptr && storage.total() * storage.elemSize() >= needed) {
    return cv::Mat(rows, cols, type, storage.data);
  }
  return NewLargeMat(rows, cols, type);
}

}  // namespace curvecheck
