// The content of a decoded image, as a hash: two photos with the same pixels (the same file twice, a copy under
// another name, or a lossless re-encoding: PNG at another compression level, TIFF) have the same hash; any
// pixel, the size or the pixel type differing gives another (metrology.md section 3: "the same photo twice"
// must not count twice). `calibrate` and `analyze` use it to take each photo's content once.
//
// Hash it what is analysed: the decoded image as the caller uses it (e.g. ReadPhotoGray's or DecodePhotoGray's
// gray image), so that what counts as "the same" is what would give the same measurement. A lossy re-encoding
// (JPEG saved again) changes the pixels and is another photo.
//
// The hash is 128 bits over the image's size, pixel type and every row's bytes (row padding of a
// non-continuous cv::Mat excluded): two 64-bit lanes of multiply-rotate rounds on 8-byte words, each finished
// with a full avalanche. Not cryptographic (a crafted collision is possible); between the photos of one
// measurement an accidental collision is beyond any practical chance (~n^2 / 2^129). Speed: one pass at
// memory speed (~10 ms for a 24 MP 8-bit photo).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace curvecheck {

struct ContentHash {
  uint64_t hi = 0, lo = 0;
  int width = 0, height = 0;
  int type = 0;  // OpenCV type (depth and channels), e.g. CV_8UC1

  bool operator==(const ContentHash& other) const = default;
  // 32 lowercase hex digits (hi then lo).
  std::string Hex() const;
  // "640x480 8-bit gray, content 0123456789abcdef..." (the hash's first 16 hex digits): for notes and reports.
  std::string Describe() const;
};

// The hash of `image`'s content (see above). An empty image hashes to its own value (size 0x0).
ContentHash HashImageContent(const cv::Mat& image);

}  // namespace curvecheck
