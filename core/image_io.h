// Image files. PNG only for outputs (lossless, 8 or 16 bit); reading accepts what OpenCV decodes. Outputs are
// written atomically (encoded in memory by core/png_encode.h on all cores, then WriteFileAtomic).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace curvecheck {

// Writes an 8-bit image with 1 (gray), 3 (BGR) or 4 (BGRA) channels, rows top to bottom, tightly packed.
void WritePng8(const std::filesystem::path& path, int width, int height, int channels, const uint8_t* data);

// Writes a 16-bit gray image, rows top to bottom.
void WritePng16(const std::filesystem::path& path, int width, int height, const uint16_t* data);

// 200 Mpx: above the largest camera sensors (~150 Mpx) and any display; 600 MB as 8-bit colour.
constexpr uint64_t kMaxImagePixels = 200'000'000;

struct Image8 {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;  // rows top to bottom, tightly packed; BGR(A) order for colour
};
// Reads an image as 8-bit (16-bit files are scaled down). PNG, JPEG, TIFF or BMP, at most kMaxImagePixels as its
// header declares (checked before decoding, so that a small damaged or hostile file cannot make OpenCV allocate
// gigabytes). Throws Error naming the file if it is missing, truncated, not such an image or too large.
Image8 ReadImage8(const std::filesystem::path& path);
// The same from the bytes of an image file; `source` names it in errors. The entry point for the fuzzer
// (fuzz/fuzz_image.cc) and for images already in memory.
Image8 DecodeImage8(std::string_view bytes, const std::string& source);
// The header check of DecodeImage8 alone, for readers that decode with OpenCV themselves (16-bit photos in
// analysis/): throws the same Error if the bytes are not a PNG, JPEG, TIFF or BMP, the header is damaged, or it
// declares 0 px or more than kMaxImagePixels. Decodes nothing.
void CheckImageHeader(std::string_view bytes, const std::string& source);

// Colour-maps a float map (NaN = no data, drawn dark grey; infinity = failure, drawn magenta) on [0, max_value]
// with a perceptual colour scale (OpenCV's viridis) and writes it as PNG; values above max_value saturate.
void WriteHeatmapPng(const std::filesystem::path& path, int width, int height, const std::vector<float>& values,
                     double max_value);

}  // namespace curvecheck
