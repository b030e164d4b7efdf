#include "core/png_encode.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace curvecheck {
namespace {

// A smooth gradient with a checkerboard and noise over it (every filter type wins somewhere), `rows` tall so that
// the image spans several strips (1 MB each) with a short last one.
cv::Mat TestImage(int rows, int cols, int type) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(7);
  const double top = image.depth() == CV_16U ? 65535 : 255;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      for (int c = 0; c < image.channels(); ++c) {
        const double gradient = (x + 2 * y + 40 * c) % 200 / 200.0;
        const double board = ((x / 16 + y / 16) % 2) * 0.3;
        const double v = std::clamp((0.5 * gradient + board + rng.gaussian(0.02)) * top, 0.0, top);
        if (image.depth() == CV_16U) {
          image.ptr<uint16_t>(y)[x * image.channels() + c] = static_cast<uint16_t>(v);
        } else {
          image.ptr<uint8_t>(y)[x * image.channels() + c] = static_cast<uint8_t>(v);
        }
      }
    }
  }
  return image;
}

// The strips' PNG decodes to the image itself, for every type written, and is within 1% of the size of OpenCV's
// own (libpng) encoding at the same compression level, whose filter choice it copies.
TEST(PngEncode, DecodesToTheImageAndMatchesLibpngsSize) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    const cv::Mat image = TestImage(1500, 700, type);
    const std::vector<uint8_t> png = EncodePng(image);
    const cv::Mat back = cv::imdecode(png, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(back.type(), type);
    EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0) << "type " << type;
    std::vector<uint8_t> reference;
    ASSERT_TRUE(cv::imencode(".png", image, reference, {cv::IMWRITE_PNG_COMPRESSION, 3}));
    const double ratio = static_cast<double>(png.size()) / static_cast<double>(reference.size());
    std::cout << "type " << type << ": " << png.size() << " bytes, libpng " << reference.size() << "\n";
    EXPECT_NEAR(ratio, 1.0, 0.01) << "type " << type;
  }
}

// One pixel, and one row, are PNG files too; the bytes do not depend on the thread count.
TEST(PngEncode, TinyImagesAndTheSameBytesOnAnyThreadCount) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(5000, 1), cv::Size(1, 3000)}) {
    const cv::Mat image = TestImage(size.height, size.width, CV_8UC3);
    const cv::Mat back = cv::imdecode(EncodePng(image), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0) << size;
  }
  const cv::Mat image = TestImage(2000, 900, CV_8UC3);
  const int threads = cv::getNumThreads();
  const std::vector<uint8_t> parallel = EncodePng(image);
  cv::setNumThreads(1);
  const std::vector<uint8_t> serial = EncodePng(image);
  cv::setNumThreads(threads);
  EXPECT_EQ(parallel, serial);
}

TEST(PngEncode, RefusesOtherTypes) {
  EXPECT_ANY_THROW(EncodePng(cv::Mat(4, 4, CV_32FC1)));
  EXPECT_ANY_THROW(EncodePng(cv::Mat(4, 4, CV_8UC2)));
  EXPECT_ANY_THROW(EncodePng(cv::Mat()));
}

}  // namespace
}  // namespace curvecheck
