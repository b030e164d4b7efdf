// Large buffers written once in full (the 24 MP synthetic photo's stages are 50-300 MB each), backed by
// transparent huge pages where the kernel offers them (THP in its "madvise" mode, Debian's default): their first
// touch then costs one page fault per 2 MB instead of one per 4 KB. On the shared 2-core VM the 4 KB faults of the
// synthetic photo's ~1.1 GB of fresh buffers were about a third of its CPU time (issue 18: 320,000 minor faults,
// 13.9 CPU-s; with huge pages 15,000 faults, 9 CPU-s).
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>

namespace curvecheck {

// Asks the kernel to back [data, data + bytes) with huge pages (madvise MADV_HUGEPAGE on the whole 4 KB pages
// inside it). Call before the memory is first touched; touched pages are not moved. Does nothing for buffers below
// 4 MB or where the kernel refuses (THP off, not Linux).
void AdviseHugePages(void* data, size_t bytes);

// An uninitialised rows x cols Mat of `type` with AdviseHugePages applied: for a large image that the caller
// writes in full (or that an OpenCV function given it as its output fills: create() keeps a Mat of the right size
// and type).
cv::Mat NewLargeMat(int rows, int cols, int type);

// A rows x cols Mat of `type` over the bytes of `storage` when it is continuous and holds enough of them (the
// caller keeps `storage` alive and is done with its values), else NewLargeMat: a stage's output in the memory of
// an earlier stage's, which costs no fresh pages at all.
cv::Mat ReuseOrNewLargeMat(const cv::Mat& storage, int rows, int cols, int type);

}  // namespace curvecheck
