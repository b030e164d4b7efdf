#include "core/png_encode.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "core/error.h"

namespace curvecheck {
namespace {

constexpr size_t kWindow = 32768;         // deflate's window: each strip's dictionary
constexpr size_t kStripBytes = 1u << 20;  // filtered bytes per strip (about 60 rows of a 24 MP colour photo)
constexpr int kLevel = 3;                 // as WritePng8 asked of OpenCV before (IMWRITE_PNG_COMPRESSION 3)

void PutBe32(std::vector<uint8_t>* out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(v >> shift));
}

// Appends the chunk `type` with `data` (length, type, data, CRC-32 of type and data).
void PutChunk(std::vector<uint8_t>* out, const char* type, const uint8_t* data, size_t size) {
  PutBe32(out, static_cast<uint32_t>(size));
  const size_t at = out->size();
  out->insert(out->end(), type, type + 4);
  if (size > 0) out->insert(out->end(), data, data + size);
  PutBe32(out, static_cast<uint32_t>(crc32(0, out->data() + at, static_cast<uInt>(size + 4))));
}

inline int Paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
}

// The filtered byte x - predicted (mod 256) for PNG filter `type` (0 None, 1 Sub, 2 Up, 3 Average, 4 Paeth) from
// the bytes left (a), above (b) and above-left (c).
inline uint8_t Filtered(int type, int x, int a, int b, int c) {
  switch (type) {
    case 0: return static_cast<uint8_t>(x);
    case 1: return static_cast<uint8_t>(x - a);
    case 2: return static_cast<uint8_t>(x - b);
    case 3: return static_cast<uint8_t>(x - ((a + b) >> 1));
    default: return static_cast<uint8_t>(x - Paeth(a, b, c));
  }
}

// libpng's measure of a filtered byte (png_write_find_filter): its value as signed, in absolute value.
inline size_t Cost(int filtered) {
  const int v = filtered & 0xff;
  return static_cast<size_t>(v < 128 ? v : 256 - v);
}

// Filters one row (`raw`, `prev` the row above, zeros for the first; n bytes, bpp per pixel) into out[0] (the
// filter type) and out[1..n]: libpng's default adaptive choice, the filter whose bytes have the least summed
// Cost, the earliest on a tie (None, Sub, Up, Average, Paeth). One pass measures all five, a second writes the
// chosen one.
void FilterRow(const uint8_t* raw, const uint8_t* prev, size_t n, size_t bpp, uint8_t* out) {
  std::array<size_t, 5> cost{};
  const size_t head = std::min(bpp, n);  // bytes without a left neighbour: a = c = 0
  for (size_t i = 0; i < head; ++i) {
    for (int t = 0; t < 5; ++t) cost[static_cast<size_t>(t)] += Cost(Filtered(t, raw[i], 0, prev[i], 0));
  }
  for (size_t i = head; i < n; ++i) {
    const int x = raw[i], a = raw[i - bpp], b = prev[i], c = prev[i - bpp];
    cost[0] += Cost(x);
    cost[1] += Cost(x - a);
    cost[2] += Cost(x - b);
    cost[3] += Cost(x - ((a + b) >> 1));
    cost[4] += Cost(x - Paeth(a, b, c));
  }
  int type = 0;
  for (int t = 1; t < 5; ++t) {
    if (cost[static_cast<size_t>(t)] < cost[static_cast<size_t>(type)]) type = t;
  }
  out[0] = static_cast<uint8_t>(type);
  for (size_t i = 0; i < head; ++i) out[1 + i] = Filtered(type, raw[i], 0, prev[i], 0);
  for (size_t i = head; i < n; ++i) out[1 + i] = Filtered(type, raw[i], raw[i - bpp], prev[i], prev[i - bpp]);
}

// The row y of `image` as PNG stores it: R, G, B(, A) order, 16-bit samples big-endian.
void RawRow(const cv::Mat& image, int y, uint8_t* raw) {
  const int channels = image.channels(), width = image.cols;
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(channels);
  if (image.depth() == CV_16U) {
    const uint16_t* in = image.ptr<uint16_t>(y);
    for (size_t i = 0; i < n; ++i) {
      const size_t c = i % static_cast<size_t>(channels);
      // OpenCV's B, G, R(, A) to R, G, B(, A).
      const uint16_t v = in[channels >= 3 && c < 3 ? i - c + (2 - c) : i];
      raw[2 * i] = static_cast<uint8_t>(v >> 8);
      raw[2 * i + 1] = static_cast<uint8_t>(v & 0xff);
    }
    return;
  }
  const uint8_t* in = image.ptr<uint8_t>(y);
  if (channels == 1) {
    std::memcpy(raw, in, n);
    return;
  }
  for (size_t i = 0; i < n; i += static_cast<size_t>(channels)) {
    raw[i] = in[i + 2];
    raw[i + 1] = in[i + 1];
    raw[i + 2] = in[i];
    if (channels == 4) raw[i + 3] = in[i + 3];
  }
}

}  // namespace

std::vector<uint8_t> EncodePng(const cv::Mat& image) {
  const int depth = image.depth(), channels = image.channels();
  if ((depth != CV_8U && depth != CV_16U) || (channels != 1 && channels != 3 && channels != 4) || image.empty()) {
    throw Error("PNG encoding", fmt::format("cannot write an image of OpenCV type {} as PNG", image.type()),
                "give 8- or 16-bit gray, BGR or BGRA");
  }
  const size_t bpp = static_cast<size_t>(channels) * (depth == CV_16U ? 2 : 1);
  const size_t row_bytes = bpp * static_cast<size_t>(image.cols), line = row_bytes + 1;
  const int rows = image.rows;
  const int rows_per_strip = static_cast<int>(std::max<size_t>(1, kStripBytes / line));
  const int strips = (rows + rows_per_strip - 1) / rows_per_strip;
  // Rows before a strip whose filtered bytes cover its dictionary (the stream's 32 KB before the strip).
  const int dictionary_rows = static_cast<int>((kWindow + line - 1) / line);
  std::vector<std::vector<uint8_t>> deflated(static_cast<size_t>(strips));
  std::vector<uLong> adler(static_cast<size_t>(strips));
  std::vector<size_t> strip_bytes(static_cast<size_t>(strips));
  std::atomic<bool> failed{false};
  // Each strip: its rows, and the rows before it that hold its dictionary, filtered into a buffer of its own
  // (a row's filtering needs only the row above), then deflated.
  cv::parallel_for_(cv::Range(0, strips), [&](const cv::Range& range) {
    std::vector<uint8_t> prev(row_bytes), raw(row_bytes);
    const size_t capacity = line * static_cast<size_t>(rows_per_strip + dictionary_rows);
    const std::unique_ptr<uint8_t[]> filtered(new uint8_t[capacity]);
    std::unique_ptr<uint8_t[]> compressed;  // deflate's output, uninitialised (a zero fill was 5% of the write)
    size_t compressed_capacity = 0;
    for (int k = range.start; k < range.end; ++k) {
      const int y0 = k * rows_per_strip, y1 = std::min(rows, y0 + rows_per_strip);
      const int first = std::max(0, y0 - dictionary_rows);
      if (first > 0) {
        RawRow(image, first - 1, prev.data());
      } else {
        std::fill(prev.begin(), prev.end(), 0);
      }
      for (int y = first; y < y1; ++y) {
        RawRow(image, y, raw.data());
        FilterRow(raw.data(), prev.data(), row_bytes, bpp, filtered.get() + line * static_cast<size_t>(y - first));
        std::swap(prev, raw);
      }
      const size_t begin = line * static_cast<size_t>(y0 - first), end = line * static_cast<size_t>(y1 - first);
      z_stream z{};
      if (deflateInit2(&z, kLevel, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
        failed = true;
        return;
      }
      const size_t dictionary = std::min(begin, kWindow);
      if (dictionary > 0) deflateSetDictionary(&z, filtered.get() + begin - dictionary, static_cast<uInt>(dictionary));
      // Each strip's stream ends on a byte boundary (Z_SYNC_FLUSH), the last one as the final block (Z_FINISH).
      const bool last = k + 1 == strips;
      const size_t bound = deflateBound(&z, static_cast<uLong>(end - begin)) + 16;
      if (bound > compressed_capacity) {
        compressed.reset(new uint8_t[bound]);
        compressed_capacity = bound;
      }
      z.next_in = filtered.get() + begin;
      z.avail_in = static_cast<uInt>(end - begin);
      z.next_out = compressed.get();
      z.avail_out = static_cast<uInt>(bound);
      const int status = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
      if (!(last ? status == Z_STREAM_END : status == Z_OK && z.avail_in == 0)) failed = true;
      deflated[static_cast<size_t>(k)].assign(compressed.get(), compressed.get() + (bound - z.avail_out));
      deflateEnd(&z);
      adler[static_cast<size_t>(k)] = adler32(1, filtered.get() + begin, static_cast<uInt>(end - begin));
      strip_bytes[static_cast<size_t>(k)] = end - begin;
    }
  });
  if (failed) throw Error("PNG encoding", "zlib could not compress the image", "check the available memory");
  // The zlib stream: header (deflate, 32 KB window, level 2-5), the strips, the Adler-32 of all the data.
  std::vector<uint8_t> idat = {0x78, 0x5e};
  size_t idat_bytes = 2 + 4;
  for (const auto& d : deflated) idat_bytes += d.size();
  idat.reserve(idat_bytes);
  uLong sum = adler32(0, nullptr, 0);
  for (size_t k = 0; k < deflated.size(); ++k) {
    idat.insert(idat.end(), deflated[k].begin(), deflated[k].end());
    sum = adler32_combine(sum, adler[k], static_cast<z_off_t>(strip_bytes[k]));
  }
  PutBe32(&idat, static_cast<uint32_t>(sum));

  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  png.reserve(idat.size() + 64);
  std::vector<uint8_t> ihdr;
  PutBe32(&ihdr, static_cast<uint32_t>(image.cols));
  PutBe32(&ihdr, static_cast<uint32_t>(rows));
  const uint8_t colour_type = channels == 1 ? 0 : channels == 3 ? 2 : 6;
  ihdr.insert(ihdr.end(), {static_cast<uint8_t>(depth == CV_16U ? 16 : 8), colour_type, 0, 0, 0});
  PutChunk(&png, "IHDR", ihdr.data(), ihdr.size());
  PutChunk(&png, "IDAT", idat.data(), idat.size());
  PutChunk(&png, "IEND", nullptr, 0);
  return png;
}

}  // namespace curvecheck
