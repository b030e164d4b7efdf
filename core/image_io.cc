#include "core/image_io.h"

#include <fmt/format.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {

void WritePng8(const std::filesystem::path& path, int width, int height, int channels, const uint8_t* data) {
  if (channels != 1 && channels != 3 && channels != 4) {
    throw Error(path.string(), fmt::format("cannot write {} channels as PNG", channels), "use 1, 3 or 4");
  }
  const cv::Mat mat(height, width, CV_8UC(channels), const_cast<uint8_t*>(data));
  std::vector<uint8_t> bytes;
  if (!cv::imencode(".png", mat, bytes, {cv::IMWRITE_PNG_COMPRESSION, 3})) {
    throw Error(path.string(), "PNG encoding failed", "check the image size");
  }
  WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

void WritePng16(const std::filesystem::path& path, int width, int height, const uint16_t* data) {
  const cv::Mat mat(height, width, CV_16UC1, const_cast<uint16_t*>(data));
  std::vector<uint8_t> bytes;
  if (!cv::imencode(".png", mat, bytes, {cv::IMWRITE_PNG_COMPRESSION, 3})) {
    throw Error(path.string(), "PNG encoding failed", "check the image size");
  }
  WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Image8 ReadImage8(const std::filesystem::path& path) { return DecodeImage8(ReadFileToString(path), path.string()); }

Image8 DecodeImage8(std::string_view bytes, const std::string& source) {
  const std::filesystem::path path(source);
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  cv::Mat img;
  try {
    img = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    img = cv::Mat();
  }
  if (img.empty()) {
    throw Error(path.string(), "is not a readable image (corrupt, truncated or unsupported format)",
                "give a PNG or JPEG file");
  }
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
