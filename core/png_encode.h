// PNG encoding on all cores. The file is compressed as OpenCV's cv::imencode(".png") compresses it with
// IMWRITE_PNG_COMPRESSION 3 (libpng's adaptive filter choice per row, zlib level 3, default strategy, 32 KB
// window), but by strips of rows that are filtered and deflated in parallel (cv::parallel_for_): each strip's
// deflate stream starts from the previous strip's last 32 KB as its dictionary and ends on a byte boundary
// (Z_SYNC_FLUSH), as pigz does, so the strips join into one zlib stream of about the same size. The strips are
// fixed by the image's size, never by the thread count, so the bytes are the same on any machine. A 24 MP colour
// photo took 1.0 CPU-s in one thread through OpenCV (libpng), the largest serial part of `capture synth` (issue 18).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace curvecheck {

// The PNG file of `image`: CV_8U or CV_16U with 1 (gray), 3 (B, G, R) or 4 (B, G, R, A) channels, written as
// gray, RGB or RGBA of 8 or 16 bits. Throws Error for another type.
std::vector<uint8_t> EncodePng(const cv::Mat& image);

}  // namespace curvecheck
