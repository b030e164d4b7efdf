#include "core/image_hash.h"

#include <fmt/format.h>

#include <cstring>

namespace curvecheck {
namespace {

constexpr uint64_t kPrime1 = 0x9E3779B185EBCA87ULL;  // xxHash64's primes
constexpr uint64_t kPrime2 = 0xC2B2AE3D27D4EB4FULL;
constexpr uint64_t kPrime3 = 0x165667B19E3779F9ULL;
constexpr uint64_t kPrime4 = 0x85EBCA77C2B2AE63ULL;

inline uint64_t Rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

// One round per 8-byte word and lane (xxHash64's round with lane-specific constants).
inline uint64_t Round1(uint64_t h, uint64_t w) { return Rotl(h + w * kPrime2, 31) * kPrime1; }
inline uint64_t Round2(uint64_t h, uint64_t w) { return Rotl(h + w * kPrime4, 27) * kPrime3; }

// The full avalanche of splitmix64/murmur3's finaliser.
inline uint64_t Avalanche(uint64_t x) {
  x ^= x >> 33;
  x *= 0xFF51AFD7ED558CCDULL;
  x ^= x >> 33;
  x *= 0xC4CEB9FE1A85EC53ULL;
  x ^= x >> 33;
  return x;
}

struct Lanes {
  uint64_t a = kPrime1, b = kPrime3;
  uint64_t bytes = 0;
  void Word(uint64_t w) {
    a = Round1(a, w);
    b = Round2(b, w ^ Rotl(w, 17));
  }
  void Bytes(const uint8_t* p, size_t n) {
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      Word(w);
    }
    // The tail (< 8 bytes) with its length, so that rows of different widths never alias.
    uint64_t w = 0;
    std::memcpy(&w, p + i, n - i);
    Word(w ^ (static_cast<uint64_t>(n - i) << 56));
    bytes += n;
  }
};

}  // namespace

std::string ContentHash::Hex() const { return fmt::format("{:016x}{:016x}", hi, lo); }

std::string ContentHash::Describe() const {
  const int depth = CV_MAT_DEPTH(type), channels = CV_MAT_CN(type);
  const int bits = depth == CV_8U || depth == CV_8S ? 8 : depth == CV_16U || depth == CV_16S || depth == CV_16F ? 16
                   : depth == CV_64F                ? 64
                                                    : 32;
  const std::string layout = channels == 1 ? "gray" : fmt::format("{} channels", channels);
  return fmt::format("{}x{} {}-bit {}, content {}", width, height, bits, layout, Hex().substr(0, 16));
}

ContentHash HashImageContent(const cv::Mat& image) {
  ContentHash h;
  h.width = image.cols;
  h.height = image.rows;
  h.type = image.type();
  Lanes lanes;
  lanes.Word((static_cast<uint64_t>(static_cast<uint32_t>(h.width)) << 32) | static_cast<uint32_t>(h.height));
  lanes.Word(static_cast<uint64_t>(static_cast<uint32_t>(h.type)));
  const size_t row_bytes = static_cast<size_t>(image.cols) * image.elemSize();
  for (int r = 0; r < image.rows && row_bytes > 0; ++r) lanes.Bytes(image.ptr<uint8_t>(r), row_bytes);
  h.hi = Avalanche(lanes.a ^ Rotl(lanes.b, 32) ^ lanes.bytes);
  h.lo = Avalanche(lanes.b + kPrime2 * h.hi);
  return h;
}

}  // namespace curvecheck
