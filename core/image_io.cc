#include "core/image_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <zlib.h>

#include "core/error.h"
#include "core/image_decode.h"
#include "core/file_io.h"
#include "core/png_encode.h"
#include "core/stats.h"

namespace curvecheck {

void WritePng8(const std::filesystem::path& path, int width, int height, int channels, const uint8_t* data) {
  if (channels != 1 && channels != 3 && channels != 4) {
    throw Error(path.string(), fmt::format("cannot write {} channels as PNG", channels), "use 1, 3 or 4");
  }
  const cv::Mat mat(height, width, CV_8UC(channels), const_cast<uint8_t*>(data));
  const std::vector<uint8_t> bytes = EncodePng(mat);
  WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

void WritePng16(const std::filesystem::path& path, int width, int height, const uint16_t* data) {
  const cv::Mat mat(height, width, CV_16UC1, const_cast<uint16_t*>(data));
  const std::vector<uint8_t> bytes = EncodePng(mat);
  WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

namespace {

// Big-endian / little-endian unsigned reads at `at`; the caller has checked the length.
uint64_t Be(std::string_view b, size_t at, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | static_cast<uint8_t>(b[at + static_cast<size_t>(i)]);
  return v;
}
uint64_t Le(std::string_view b, size_t at, int n) {
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(b[at + static_cast<size_t>(i)]);
  return v;
}

struct DeclaredSize {
  const char* format = nullptr;  // nullptr: not a format we read
  uint64_t width = 0, height = 0;
  bool found = false;  // false: the header is too damaged to say
  size_t jpeg_scan = 0;  // JPEG: offset of the first start-of-scan marker (0: not reached)
};

// The format and the image size its header declares, read before decoding: OpenCV allocates the whole image from
// the header before it reads any pixel data, so a 69-byte PNG declaring 30000 x 30000 px made it allocate 2.7 GB
// (found by fuzz/fuzz_image). Formats: those `capture import` takes (PNG, JPEG, TIFF, BMP).
DeclaredSize SizeFromHeader(std::string_view b) {
  DeclaredSize d;
  if (b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8)) {
    d.format = "PNG";
    if (b.size() >= 24 && b.substr(12, 4) == "IHDR") d = {d.format, Be(b, 16, 4), Be(b, 20, 4), true};
  } else if (b.size() >= 3 && Be(b, 0, 3) == 0xFFD8FF) {
    d.format = "JPEG";
    // Marker segments up to the first SOFn (C0..CF except C4 DHT, C8 JPG, CC DAC), which precedes the scan (DA).
    size_t i = 2;
    while (i + 4 <= b.size()) {
      if (static_cast<uint8_t>(b[i]) != 0xFF) break;
      const uint8_t m = static_cast<uint8_t>(b[i + 1]);
      if (m == 0xFF) { ++i; continue; }  // fill byte
      if (m == 0x01 || (m >= 0xD0 && m <= 0xD8)) { i += 2; continue; }  // markers without a length
      if (m == 0xDA) {
        d.jpeg_scan = i;
        break;
      }
      if (m == 0xD9) break;
      if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC && !d.found && i + 9 <= b.size()) {
        d = {d.format, Be(b, i + 7, 2), Be(b, i + 5, 2), true};  // go on to the scan (completeness check)
      }
      i += 2 + Be(b, i + 2, 2);
    }
  } else if (b.size() >= 2 && b.substr(0, 2) == "BM") {
    d.format = "BMP";
    if (b.size() >= 26) {
      const auto w = static_cast<int32_t>(Le(b, 18, 4)), h = static_cast<int32_t>(Le(b, 22, 4));  // h < 0: top-down
      d = {d.format, static_cast<uint64_t>(std::abs(static_cast<int64_t>(w))),
           static_cast<uint64_t>(std::abs(static_cast<int64_t>(h))), true};
    }
  } else if (b.size() >= 8 && (b.substr(0, 4) == std::string_view("II*\0", 4) || b.substr(0, 4) == "MM\0*")) {
    d.format = "TIFF";
    const bool le = b[0] == 'I';
    const auto u = [&](size_t at, int n) { return le ? Le(b, at, n) : Be(b, at, n); };
    const uint64_t ifd = u(4, 4);  // the first image (OpenCV reads that one)
    if (ifd + 2 <= b.size()) {
      const uint64_t n = u(ifd, 2);
      for (uint64_t k = 0; k < n && ifd + 2 + 12 * (k + 1) <= b.size(); ++k) {
        const size_t e = ifd + 2 + 12 * k;
        const uint64_t tag = u(e, 2), type = u(e + 2, 2);
        const uint64_t v = type == 3 ? u(e + 8, 2) : u(e + 8, 4);  // SHORT or LONG
        if (tag == 256) d.width = v;
        if (tag == 257) d.height = v;
      }
      d.found = d.width > 0 && d.height > 0;
    }
  }
  return d;
}

}  // namespace

Image8 ReadImage8(const std::filesystem::path& path) { return DecodeImage8(ReadFileToString(path), path.string()); }

void CheckImageHeader(std::string_view bytes, const std::string& source) {
  const std::filesystem::path path(source);
  const DeclaredSize declared = SizeFromHeader(bytes);
  if (!declared.format) {
    throw Error(path.string(), "is not a PNG, JPEG, TIFF or BMP image (unknown header)", "give a PNG or JPEG file");
  }
  if (!declared.found) {
    throw Error(path.string(), fmt::format("is not a readable {} image (damaged or truncated header)", declared.format),
                "give a complete PNG or JPEG file");
  }
  if (declared.width == 0 || declared.height == 0 || declared.width * declared.height > kMaxImagePixels ||
      bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    throw Error(path.string(),
                fmt::format("declares {} x {} px, outside 1 px .. {} Mpx (or is over 2 GB)", declared.width,
                            declared.height, kMaxImagePixels / 1000000),
                "give a camera photo or a rendered pattern; the file may be damaged");
  }
  // A cut-off file: libpng and libjpeg decode what is there, fill the rest and print a warning on stderr, so the
  // end is checked here. A PNG ends with its IEND chunk (trailing bytes tolerated within 1 kB); a JPEG has an
  // end-of-image marker after its scan (FF D9 cannot occur inside entropy-coded data; an EXIF thumbnail's own
  // marker lies before the scan; a trailer after it, such as a phone's video, is tolerated).
  const std::string_view tail = bytes.substr(bytes.size() - std::min<size_t>(bytes.size(), 1024));
  if (std::string_view(declared.format) == "PNG" && tail.find("IEND") == std::string_view::npos) {
    throw Error(path.string(), "is a truncated PNG (no IEND chunk at its end)", "copy or export the file again");
  }
  // A PNG damaged inside (a flipped bit, an overwritten block): every chunk carries a CRC-32 of its type and data,
  // checked here because libpng reports a mismatch by printing on stderr. Chunks are walked up to IEND; one that
  // runs past the end of the file is the truncation above.
  if (std::string_view(declared.format) == "PNG") {
    const auto be32 = [&](size_t at) {
      const auto* b = reinterpret_cast<const unsigned char*>(bytes.data()) + at;
      return (uint32_t{b[0]} << 24) | (uint32_t{b[1]} << 16) | (uint32_t{b[2]} << 8) | uint32_t{b[3]};
    };
    for (size_t at = 8; at + 12 <= bytes.size();) {
      const uint64_t length = be32(at);
      if (at + 12 + length > bytes.size()) {
        throw Error(path.string(), "is a truncated PNG (its last chunk runs past the end of the file)",
                    "copy or export the file again");
      }
      const std::string_view type = bytes.substr(at + 4, 4);
      const uint32_t crc = static_cast<uint32_t>(
          ::crc32(0, reinterpret_cast<const Bytef*>(bytes.data() + at + 4), static_cast<uInt>(length + 4)));
      if (crc != be32(at + 8 + length)) {
        throw Error(path.string(),
                    fmt::format("is a damaged PNG (its {} chunk at byte {} fails its CRC check)", type, at),
                    "copy or export the file again");
      }
      if (type == "IEND") break;
      at += 12 + length;
    }
  }
  if (std::string_view(declared.format) == "JPEG" &&
      (declared.jpeg_scan == 0 || bytes.find("\xFF\xD9", declared.jpeg_scan) == std::string_view::npos)) {
    throw Error(path.string(), "is a truncated JPEG (no end-of-image marker after its image data)",
                "copy or export the file again");
  }
}

cv::Mat DecodeImage(std::string_view bytes, const std::string& source) {
  CheckImageHeader(bytes, source);
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  cv::Mat img;
  try {
    img = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    img = cv::Mat();
  }
  if (img.empty()) {
    throw Error(source, "is not a readable image (corrupt, truncated or unsupported format)",
                "give a PNG or JPEG file");
  }
  return img;
}

namespace {

// GrayConversion::chroma_texture and bright_fraction of a 3- or 4-channel photo (ColourPhotoToGray).
template <typename T>
void MeasureChromaTexture(const cv::Mat& photo, GrayConversion* out) {
  constexpr int kRowStep = 4, kReach = 4;
  const int channels = photo.channels(), width = photo.cols, height = photo.rows;
  if (width <= 2 * kReach + 2 || height <= 2 * kReach + 2) return;
  // The channel mean, which colour aliasing leaves even, finds the bright areas; luma - mean is the chroma.
  const auto level = [&](const T* row, int x) {
    const T* p = row + static_cast<ptrdiff_t>(x) * channels;
    return (static_cast<double>(p[0]) + p[1] + p[2]) / 3;
  };
  // White level: the 99th percentile of 3-px means along the sampled rows.
  std::vector<float> means;
  for (int y = kReach; y < height - kReach; y += kRowStep) {
    const T* row = photo.ptr<T>(y);
    for (int x = 1; x + 1 < width; x += 3) {
      means.push_back(static_cast<float>((level(row, x - 1) + level(row, x) + level(row, x + 1)) / 3));
    }
  }
  const double white = WhiteLevel(std::move(means));
  if (!(white > 0)) return;
  const double bright = kBrightOfWhite * white;
  double n = 0, sum = 0, sum2 = 0, sampled = 0;
  for (int y = kReach; y < height - kReach; y += kRowStep) {
    const T* row = photo.ptr<T>(y);
    const T* up = photo.ptr<T>(y - kReach);
    const T* down = photo.ptr<T>(y + kReach);
    for (int x = kReach; x < width - kReach; ++x) {
      sampled += 1;
      const double m = level(row, x);
      if (m < bright || level(row, x - kReach) < bright || level(row, x + kReach) < bright || level(up, x) < bright ||
          level(down, x) < bright) {
        continue;
      }
      const T* p = row + static_cast<ptrdiff_t>(x) * channels;
      const double chroma = 0.114 * p[0] + 0.587 * p[1] + 0.299 * p[2] - m;
      n += 1;
      sum += chroma;
      sum2 += chroma * chroma;
    }
  }
  out->bright_fraction = sampled > 0 ? n / sampled : 0;
  if (n < 100) return;
  const double mean = sum / n;
  out->chroma_texture = std::sqrt(std::max(0.0, sum2 / n - mean * mean)) / white;
}

}  // namespace

cv::Mat ColourPhotoToGray(const cv::Mat& photo, GrayConversion* conversion) {
  GrayConversion c;
  if (photo.channels() != 3 && photo.channels() != 4) {
    if (conversion) *conversion = c;
    return photo;
  }
  c.colour = true;
  if (photo.depth() == CV_16U) {
    MeasureChromaTexture<uint16_t>(photo, &c);
  } else if (photo.depth() == CV_8U) {
    MeasureChromaTexture<uint8_t>(photo, &c);
  }
  c.channel_mean = c.chroma_texture >= kColourAliasingLimit;
  cv::Mat gray;
  if (!c.channel_mean) {
    cv::cvtColor(photo, gray, photo.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  } else {
    constexpr float kThird = 1.0f / 3.0f;
    if (photo.channels() == 3) {
      cv::transform(photo, gray, cv::Matx13f(kThird, kThird, kThird));
    } else {
      cv::transform(photo, gray, cv::Matx14f(kThird, kThird, kThird, 0.0f));
    }
  }
  if (conversion) *conversion = c;
  return gray;
}

Image8 DecodeImage8(std::string_view bytes, const std::string& source) {
  const std::filesystem::path path(source);
  cv::Mat img = DecodeImage(bytes, source);
  if (img.depth() == CV_16U) img.convertTo(img, CV_8U, 1.0 / 257.0);
  if (img.depth() != CV_8U) throw Error(path.string(), "has an unsupported pixel type", "give an 8 or 16 bit image");
  Image8 out;
  out.width = img.cols;
  out.height = img.rows;
  out.channels = img.channels();
  out.pixels.resize(img.total() * img.elemSize());
  if (img.isContinuous()) {
    std::memcpy(out.pixels.data(), img.data, out.pixels.size());
  } else {
    for (int r = 0; r < img.rows; ++r) {
      std::memcpy(out.pixels.data() + r * img.cols * img.elemSize(), img.ptr(r), img.cols * img.elemSize());
    }
  }
  return out;
}

void WriteHeatmapPng(const std::filesystem::path& path, int width, int height, const std::vector<float>& values,
                     double max_value) {
  cv::Mat gray(height, width, CV_8U), mask(height, width, CV_8U), missing(height, width, CV_8U);
  for (int i = 0; i < width * height; ++i) {
    const float v = values[static_cast<size_t>(i)];
    mask.data[i] = std::isnan(v) ? 0 : 255;
    missing.data[i] = std::isinf(v) ? 255 : 0;
    const double t = std::isfinite(v) ? std::clamp(v / max_value, 0.0, 1.0) : 0;
    gray.data[i] = static_cast<uint8_t>(std::lround(255 * t));
  }
  cv::Mat colour;
  cv::applyColorMap(gray, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar(48, 48, 48), mask == 0);
  colour.setTo(cv::Scalar(255, 0, 255), missing);  // infinite error (a pixel the method did not draw): magenta
  WritePng8(path, width, height, 3, colour.data);
}

}  // namespace curvecheck
