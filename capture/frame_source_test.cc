#include "capture/frame_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "core/test_util.h"

namespace curvecheck {
namespace {

using ::testing::HasSubstr;
using testing::MessageOf;

// Standard deviation of (frame - 100) over all pixels.
double NoiseStd(const cv::Mat& m) {
  cv::Scalar mean, stddev;
  cv::meanStdDev(m, mean, stddev);
  return stddev[0];
}

// Independent Gaussian noise (sigma 8 code values) around a flat grey of 100 in every frame; averaging N
// frames must bring the noise down by about sqrt(N) (rounding to 8 bit adds a floor of 1/sqrt(12) = 0.29).
TEST(FrameSource, AveragingReducesNoiseBySqrtN) {
  std::mt19937 rng(42);
  FakeSource noisy([&rng](int) {
    cv::Mat f(200, 200, CV_8UC1);
    std::normal_distribution<double> noise(100, 8);
    for (int i = 0; i < f.rows * f.cols; ++i) f.data[i] = cv::saturate_cast<uint8_t>(noise(rng));
    return f;
  });
  const double single = NoiseStd(GrabAveraged(noisy, 1).image);
  EXPECT_NEAR(single, 8, 0.3);
  for (int n : {4, 16}) {
    const Capture c = GrabAveraged(noisy, n);
    const double expected = std::sqrt(single * single / n + 1.0 / 12);
    EXPECT_NEAR(NoiseStd(c.image), expected, 0.1 * expected) << n << " frames";
    EXPECT_EQ(c.metadata["frames_averaged"], n);
    EXPECT_NEAR(cv::mean(c.image)[0], 100, 0.2);  // rounded, not truncated
  }
  EXPECT_EQ(noisy.grabs(), 1 + 4 + 16);
}

TEST(FrameSource, AverageRejectsMixedSizes) {
  EXPECT_THAT(MessageOf([] { AverageFrames({cv::Mat(2, 2, CV_8UC1), cv::Mat(3, 2, CV_8UC1)}); }),
              HasSubstr("frames differ in size"));
  EXPECT_THAT(MessageOf([] { AverageFrames({}); }), HasSubstr("no frames"));
}

TEST(FrameSource, FakeFailsWhereTold) {
  FakeSource fake([](int) { return cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)); });
  fake.FailAt(2, "cable pulled");
  EXPECT_EQ(fake.Grab().image.cols, 4);
  EXPECT_THAT(MessageOf([&] { fake.Grab(); }), HasSubstr("fake source: cable pulled"));
  EXPECT_EQ(fake.Grab().metadata["grab"], 3);
}

// No V4L2 device on a test machine: the error says so and what to do (and OpenCV is never asked to open it).
TEST(FrameSource, NoV4l2CameraIsAClearError) {
  OpenCvCameraOptions o;
  o.device = "/dev/video99";
  EXPECT_EQ(MessageOf([&] { OpenCvCameraSource s(o); }),
            "no camera found: /dev/video99 does not exist or cannot be opened; check the device "
            "(v4l2-ctl --list-devices) or use --device");
  o.device = "98";
  EXPECT_THAT(MessageOf([&] { OpenCvCameraSource s(o); }), HasSubstr("/dev/video98 does not exist"));
  o.frames = 0;
  EXPECT_THAT(MessageOf([&] { OpenCvCameraSource s(o); }), HasSubstr("--frames: is 0"));
}

// No camera on USB: libgphoto2's autodetect finds none (this test assumes a machine without a camera).
TEST(FrameSource, NoGphoto2CameraIsAClearError) {
  EXPECT_THAT(MessageOf([] { Gphoto2Source s; }), HasSubstr("no camera found: libgphoto2 "));
}

// Photos from files and cameras are decoded through core's DecodeImage8: gray and BGRA come out BGR, and a file
// whose header declares more than kMaxImagePixels is refused before OpenCV allocates it.
TEST(FrameSource, DecodePhotoBgrAppliesTheHeaderCheckAndSizeCap) {
  std::vector<uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(5, 7, CV_8UC1, cv::Scalar(9)), png));
  const cv::Mat bgr = DecodePhotoBgr(std::string(png.begin(), png.end()), "gray.png");
  EXPECT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.cols, 7);
  EXPECT_EQ(bgr.at<cv::Vec3b>(4, 6), cv::Vec3b(9, 9, 9));
  std::string huge(png.begin(), png.end());
  for (int i : {16, 20}) huge.replace(static_cast<size_t>(i), 4, std::string("\x00\x00\x75\x30", 4));  // 30000 px
  EXPECT_THAT(MessageOf([&] { DecodePhotoBgr(huge, "huge.png"); }),
              HasSubstr("huge.png: declares 30000 x 30000 px, outside 1 px .. 200 Mpx"));
  EXPECT_THAT(MessageOf([&] { DecodePhotoBgr("GIF89a", "x.gif"); }), HasSubstr("x.gif: is not a PNG, JPEG"));
}

TEST(FrameSource, UtcTimeIsIso8601) {
  const std::string t = NowUtcIso8601();
  ASSERT_EQ(t.size(), 24u) << t;
  EXPECT_EQ(t[10], 'T');
  EXPECT_EQ(t.back(), 'Z');
}

}  // namespace
}  // namespace curvecheck
