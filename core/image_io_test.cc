#include "core/image_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image_decode.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using ::testing::HasSubstr;

std::string Encode(const cv::Mat& m, const char* ext) {
  std::vector<uint8_t> buf;
  EXPECT_TRUE(cv::imencode(ext, m, buf)) << ext;
  return std::string(buf.begin(), buf.end());
}

cv::Mat Board(int type) {
  cv::Mat m(6, 8, type);
  for (int r = 0; r < m.rows; ++r) {
    for (int c = 0; c < m.cols; ++c) {
      const int v = ((r / 2 + c / 2) % 2) * 255;
      if (m.depth() == CV_16U) {
        m.at<uint16_t>(r, c) = static_cast<uint16_t>(v * 257);
      } else if (m.channels() == 3) {
        m.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<uint8_t>(v), 0, static_cast<uint8_t>(255 - v));
      } else {
        m.at<uint8_t>(r, c) = static_cast<uint8_t>(v);
      }
    }
  }
  return m;
}

// The header check in front of OpenCV must let every real file of the four formats through, with its size.
TEST(ImageIo, DecodesPngJpegTiffBmp) {
  for (const char* ext : {".png", ".jpg", ".tiff", ".bmp"}) {
    for (int type : {CV_8UC1, CV_8UC3}) {
      const Image8 img = DecodeImage8(Encode(Board(type), ext), std::string("x") + ext);
      EXPECT_EQ(img.width, 8) << ext;
      EXPECT_EQ(img.height, 6) << ext;
      EXPECT_EQ(img.channels, CV_MAT_CN(type)) << ext;
      ASSERT_EQ(img.pixels.size(), size_t{8 * 6} * img.channels) << ext;
    }
  }
  // 16-bit PNG is scaled to 8 bits.
  const Image8 g16 = DecodeImage8(Encode(Board(CV_16UC1), ".png"), "g16.png");
  EXPECT_EQ(g16.pixels[0], 0);
  EXPECT_EQ(g16.pixels[2], 255);
}

// A 69-byte PNG whose header declares 30000 x 30000 px made OpenCV allocate 2.7 GB before failing on the missing
// pixel data (found by fuzz/fuzz_image; the input is fuzz/corpus/fuzz_image/huge-header.png). It is refused from the
// header now; so is anything that is not one of the four formats, or whose header is cut short.
TEST(ImageIo, RefusesHugeDeclaredSizesAndDamagedHeaders) {
  std::string png = Encode(Board(CV_8UC1), ".png");
  std::string huge = png;
  const unsigned char size[8] = {0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30};  // 30000, 30000 big-endian in IHDR
  std::memcpy(huge.data() + 16, size, 8);
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8(huge, "huge.png"); }),
              HasSubstr("huge.png: declares 30000 x 30000 px, outside 1 px .. 200 Mpx"));
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8(png.substr(0, 20), "cut.png"); }),
              HasSubstr("cut.png: is not a readable PNG image (damaged or truncated header)"));
  // Cut-off files are refused before decoding (libpng and libjpeg would decode them partly, with a warning).
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8(png.substr(0, png.size() / 2), "half.png"); }),
              HasSubstr("half.png: is a truncated PNG (no IEND chunk at its end)"));
  // Damaged inside, its end intact: the chunk's CRC-32 says so (libpng would print it on stderr).
  std::string flipped = png;
  flipped[png.size() / 2] = static_cast<char>(flipped[png.size() / 2] ^ 0x40);
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8(flipped, "flip.png"); }),
              HasSubstr("flip.png: is a damaged PNG (its IDAT chunk at byte "));
  const std::string jpeg = Encode(Board(CV_8UC1), ".jpg");
  EXPECT_EQ(DecodeImage8(jpeg + "trailer", "trailer.jpg").width, Board(CV_8UC1).cols);
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8(jpeg.substr(0, jpeg.size() - 2), "cut.jpg"); }),
              HasSubstr("cut.jpg: is a truncated JPEG (no end-of-image marker after its image data)"));
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8("P5 30000 30000 255\n", "x.pgm"); }),
              HasSubstr("x.pgm: is not a PNG, JPEG, TIFF or BMP image"));
  EXPECT_THAT(testing::MessageOf([&] { DecodeImage8("", "empty.png"); }), HasSubstr("empty.png: is not a PNG"));
}

// A white checkerboard square region of 120 x 120 px on black, as a photo of a display: `aliased` draws its white
// as single-colour columns R, G, B in turn (each at 3 x a third of white: what point samples of a display's
// stripes give), otherwise as white-balanced gray; `noise` adds independent Gaussian noise per channel.
cv::Mat DisplayPhoto(int depth, bool aliased, double noise) {
  const double full = depth == CV_16U ? 65535 : 255;
  cv::Mat m(200, 240, CV_64FC3, cv::Scalar::all(0.02 * full));
  cv::RNG rng(7);
  for (int r = 40; r < 160; ++r) {
    for (int c = 60; c < 180; ++c) {
      cv::Vec3d v = cv::Vec3d::all(0.6 * full);
      if (aliased) {
        v = cv::Vec3d::all(0);
        v[2 - c % 3] = 0.6 * full;  // B, G, R order: column 0 red, 1 green, 2 blue; channel mean 0.2 full
      }
      m.at<cv::Vec3d>(r, c) = v;
    }
  }
  if (noise > 0) {
    cv::Mat n(m.size(), CV_64FC3);
    rng.fill(n, cv::RNG::NORMAL, 0, noise * full);
    m += n;
  }
  cv::Mat out;
  m.convertTo(out, depth == CV_16U ? CV_16UC3 : CV_8UC3);
  return out;
}

// Luma unless the display's sub-pixels alias in colour; then the channel mean, which cancels the stripes.
TEST(ColourPhotoToGray, ChannelMeanWhereTheSubPixelsAliasInColourElseLuma) {
  for (const int depth : {CV_8U, CV_16U}) {
    GrayConversion c;
    const cv::Mat plain = DisplayPhoto(depth, false, 0.005);
    const cv::Mat gray = ColourPhotoToGray(plain, &c);
    EXPECT_TRUE(c.colour);
    EXPECT_FALSE(c.channel_mean) << c.chroma_texture;
    EXPECT_LT(c.chroma_texture, 0.005);  // noise of 0.5% per channel: luma - mean has sd 0.17% of it / 0.6 white
    EXPECT_GT(c.bright_fraction, 0.15);  // the square less 4 px at its edges, of the rows sampled
    cv::Mat luma;
    cv::cvtColor(plain, luma, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(cv::norm(gray, luma, cv::NORM_INF), 0);
    EXPECT_EQ(gray.depth(), depth);

    const cv::Mat aliased = DisplayPhoto(depth, true, 0.005);
    const cv::Mat mean = ColourPhotoToGray(aliased, &c);
    EXPECT_TRUE(c.channel_mean);
    // Luma of the columns 0.179, 0.352, 0.068 full about their mean 0.2 full: sd 0.117 full, over the white level
    // (the columns' channel mean, 0.2 full): 0.58.
    EXPECT_NEAR(c.chroma_texture, 0.58, 0.02);
    cv::Scalar m, sd;
    cv::meanStdDev(mean(cv::Rect(70, 50, 100, 100)), m, sd);
    const double full = depth == CV_16U ? 65535 : 255;
    EXPECT_NEAR(m[0], 0.2 * full, 0.01 * full);
    EXPECT_LT(sd[0], 0.01 * full);  // the noise over sqrt(3); luma's columns spread 0.117 full
  }
  GrayConversion c;
  const cv::Mat one(50, 50, CV_8U, cv::Scalar(9));
  EXPECT_EQ(ColourPhotoToGray(one, &c).data, one.data);  // gray: shared, as given
  EXPECT_FALSE(c.colour);
}

}  // namespace
}  // namespace curvecheck
