#include "core/image_hash.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/image_decode.h"

namespace curvecheck {
namespace {

cv::Mat Noise(int rows, int cols, int type, int seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return m;
}

std::string Encode(const cv::Mat& m, const char* ext, const std::vector<int>& params = {}) {
  std::vector<uint8_t> buf;
  EXPECT_TRUE(cv::imencode(ext, m, buf, params)) << ext;
  return std::string(buf.begin(), buf.end());
}

// The same pixels decoded from differently encoded files: the same content. PNG at two compression levels and
// TIFF are different bytes of one image.
TEST(ImageHash, LosslessReEncodingsOfTheSameImageHaveTheSameContent) {
  const cv::Mat img = Noise(37, 53, CV_8UC1, 1);
  const std::string fast = Encode(img, ".png", {cv::IMWRITE_PNG_COMPRESSION, 1});
  const std::string small = Encode(img, ".png", {cv::IMWRITE_PNG_COMPRESSION, 9});
  const std::string tiff = Encode(img, ".tiff");
  ASSERT_NE(fast, small);
  const ContentHash a = HashImageContent(DecodeImage(fast, "fast.png"));
  EXPECT_EQ(a, HashImageContent(DecodeImage(small, "small.png")));
  EXPECT_EQ(a, HashImageContent(DecodeImage(tiff, "img.tiff")));
  EXPECT_EQ(a, HashImageContent(img));
  EXPECT_EQ(a.width, 53);
  EXPECT_EQ(a.height, 37);
  EXPECT_EQ(a.type, CV_8UC1);
  EXPECT_EQ(a.Hex().size(), 32u);
  EXPECT_THAT(a.Describe(), ::testing::StartsWith("53x37 8-bit gray, content " + a.Hex().substr(0, 16)));
}

// A view into a larger image (rows not contiguous) hashes as its copy: row padding is not content.
TEST(ImageHash, ARegionOfInterestHashesAsItsCopy) {
  const cv::Mat big = Noise(40, 64, CV_16UC1, 2);
  const cv::Mat roi = big(cv::Rect(5, 3, 33, 20));
  ASSERT_FALSE(roi.isContinuous());
  EXPECT_EQ(HashImageContent(roi), HashImageContent(roi.clone()));
}

// One pixel one code value off, the same bytes in another shape, or another pixel type: other content.
TEST(ImageHash, AnyPixelSizeOrTypeDifferenceGivesAnotherHash) {
  const cv::Mat img = Noise(30, 40, CV_8UC1, 3);
  const ContentHash a = HashImageContent(img);
  cv::Mat one = img.clone();
  one.at<uint8_t>(29, 39) ^= 1;
  EXPECT_NE(a, HashImageContent(one));
  one = img.clone();
  one.at<uint8_t>(0, 0) ^= 0x80;
  EXPECT_NE(a, HashImageContent(one));
  const ContentHash reshaped = HashImageContent(img.reshape(1, 40));  // 40 x 30, same bytes
  EXPECT_NE(a, reshaped);
  EXPECT_NE(a.Hex(), reshaped.Hex());
  cv::Mat two_channels(30, 20, CV_8UC2, img.data);  // same bytes, 2 channels
  EXPECT_NE(a.Hex(), HashImageContent(two_channels).Hex());
  EXPECT_EQ(HashImageContent(cv::Mat()).width, 0);
  // Many small images that differ in one value: no two hashes alike (lanes and tails mixed).
  std::set<std::string> seen;
  for (int v = 0; v < 256; ++v) {
    for (int at = 0; at < 13; ++at) {
      cv::Mat m(1, 13, CV_8UC1, cv::Scalar(0));
      m.at<uint8_t>(0, at) = static_cast<uint8_t>(v);
      seen.insert(HashImageContent(m).Hex());
    }
  }
  EXPECT_EQ(seen.size(), 255u * 13u + 1u);  // v = 0 is the same all-zero image at every position
}

}  // namespace
}  // namespace curvecheck
