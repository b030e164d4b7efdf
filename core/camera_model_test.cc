#include "core/camera_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/file_io.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using testing::EigenNear;

CameraModel MildOpenCv8() {
  CameraModel m;
  m.lensmodel = "LENSMODEL_OPENCV8";
  m.intrinsics = {4800, 4800, 2999.5, 1999.5, -0.08, 0.05, 0.0004, -0.0003, -0.01, 0.001, 0.002, -0.002};
  m.width = 6000;
  m.height = 4000;
  return m;
}

// Unprojection is the inverse of projection (through libmrcal both ways) over the imager.
TEST(CameraModel, ProjectUnprojectRoundTrip) {
  const CameraModel m = MildOpenCv8();
  std::vector<Eigen::Vector2d> q;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(0, 5999), uy(0, 3999);
  for (int i = 0; i < 500; ++i) q.emplace_back(ux(rng), uy(rng));
  const std::vector<Eigen::Vector3d> v = UnprojectPixels(m, q);
  std::vector<Eigen::Vector3d> far;
  for (const auto& d : v) far.push_back(d * 1500.0);
  const std::vector<Eigen::Vector2d> back = ProjectPoints(m, far);
  for (size_t i = 0; i < q.size(); ++i) EXPECT_THAT(back[i], EigenNear(q[i], 1e-6));
}

// The pinhole model is x/z * f + c; gradients agree with finite differences.
// Distortion parameters far beyond any real lens are refused by Check (libmrcal's unprojection does not
// converge on them: fuzz/corpus/fuzz_cameramodel/regression-huge-distortion-slow-unproject); the bound is 1e4.
TEST(CameraModel, AbsurdDistortionIsRefused) {
  CameraModel m = MildOpenCv8();
  m.intrinsics[5] = 1e34;
  EXPECT_THAT(testing::MessageOf([&] { m.Check("cam.cameramodel"); }),
              ::testing::HasSubstr("cam.cameramodel: distortion parameter 1 is 1e+34, beyond +-10000"));
  m.intrinsics[5] = -9999;
  EXPECT_NO_THROW(m.Check("cam.cameramodel"));
}

// Splined models libmrcal cannot evaluate abort the process inside mrcal_project (fuzz/fuzz_cameramodel found
// order=3 with 4 x 3 knots): refused with a reason instead; the smallest evaluable ones project.
TEST(CameraModel, SplinedModelsMrcalCannotEvaluateAreRefused) {
  const auto model = [](const std::string& config) {
    CameraModel m;
    m.lensmodel = "LENSMODEL_SPLINED_STEREOGRAPHIC_" + config + "_fov_x_deg=100";
    m.intrinsics.assign(static_cast<size_t>(LensModelParameterCount(m.lensmodel)), 0.0);
    m.intrinsics[0] = m.intrinsics[1] = 500;
    m.intrinsics[2] = 319.5, m.intrinsics[3] = 239.5;
    m.width = 640, m.height = 480;
    return m;
  };
  for (const std::string bad : {"order=3_Nx=4_Ny=3", "order=3_Nx=3_Ny=3", "order=2_Nx=2_Ny=2", "order=1_Nx=4_Ny=4"}) {
    EXPECT_THAT(testing::MessageOf([&] { model(bad).Check("cam.cameramodel"); }),
                ::testing::HasSubstr("cannot be evaluated"))
        << bad;
  }
  CameraModel no_fov = model("order=3_Nx=5_Ny=4");
  no_fov.lensmodel = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=5_Ny=4_fov_x_deg=0";
  EXPECT_THAT(testing::MessageOf([&] { no_fov.Check("cam.cameramodel"); }), ::testing::HasSubstr("fov_x_deg is 0"));
  for (const std::string good : {"order=2_Nx=3_Ny=3", "order=3_Nx=4_Ny=4"}) {
    const CameraModel m = model(good);
    EXPECT_NO_THROW(m.Check("cam.cameramodel")) << good;
    EXPECT_NEAR(ProjectPoint(m, Eigen::Vector3d(0, 0, 1)).x(), 319.5, 1e-9) << good;
  }
}

TEST(CameraModel, PinholeAndGradients) {
  const CameraModel pin = PinholeModel(1920, 1080, 1000);
  EXPECT_THAT(ProjectPoint(pin, {0.1, -0.2, 2.0}), EigenNear(Eigen::Vector2d(959.5 + 50, 539.5 - 100), 1e-9));
  const CameraModel m = MildOpenCv8();
  const Eigen::Vector3d p(120, -80, 1400);
  std::vector<Eigen::Matrix<double, 2, 3>> grad;
  ProjectPoints(m, {p}, &grad);
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3d dp = Eigen::Vector3d::Zero();
    dp[c] = 1e-4;
    const Eigen::Vector2d fd = (ProjectPoint(m, p + dp) - ProjectPoint(m, p - dp)) / 2e-4;
    EXPECT_THAT(Eigen::Vector2d(grad[0].col(c)), EigenNear(fd, 1e-5));
  }
}

TEST(CameraModel, WriteReadRoundTripAndBadFiles) {
  const auto dir = std::filesystem::temp_directory_path() / ("curvecheck_cameramodel_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const CameraModel m = MildOpenCv8();
  WriteCameraModel(dir / "cam.cameramodel", m);
  const CameraModel r = ReadCameraModel(dir / "cam.cameramodel");
  EXPECT_EQ(r.lensmodel, "LENSMODEL_OPENCV8");
  EXPECT_EQ(r.width, 6000);
  ASSERT_EQ(r.intrinsics.size(), m.intrinsics.size());
  for (size_t i = 0; i < m.intrinsics.size(); ++i) EXPECT_NEAR(r.intrinsics[i], m.intrinsics[i], 1e-12);
  WriteFileAtomic(dir / "bad.cameramodel", "{ 'lensmodel': 'LENSMODEL_OPENCV8', ");
  EXPECT_THAT(testing::MessageOf([&] { ReadCameraModel(dir / "bad.cameramodel"); }),
              ::testing::HasSubstr("bad.cameramodel: is not a readable mrcal .cameramodel"));
  CameraModel wrong = m;
  wrong.intrinsics.pop_back();
  EXPECT_THAT(testing::MessageOf([&] { wrong.Check("x"); }), ::testing::HasSubstr("takes 12 intrinsics, got 11"));
  std::filesystem::remove_all(dir);
}

// Inputs that crashed libmrcal 2.2's parser (SEGV reading past the buffer; found by fuzz/fuzz_cameramodel, kept in
// fuzz/corpus/fuzz_cameramodel/) are refused with an Error before they reach it; without the guard in
// ParseCameraModel these cases crash the test.
TEST(CameraModel, UnterminatedStringsAndCommentsDoNotCrashMrcal) {
  for (const std::string text : {"{ 'a", "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'i ", "{ \"lensmodel", "'"}) {
    EXPECT_THAT(testing::MessageOf([&] { ParseCameraModel(text, "t.cameramodel"); }),
                ::testing::HasSubstr("t.cameramodel: has a quoted string at byte"))
        << text;
  }
  EXPECT_THAT(testing::MessageOf([&] { ParseCameraModel(std::string("{ 'a\0'", 6), "t.cameramodel"); }),
              ::testing::HasSubstr("contains a NUL byte"));
  // A comment that runs to the end of the text is ended by the '\n' the parser appends: a last comment without a
  // newline is fine, a text that is only a comment is simply not a model.
  EXPECT_THAT(testing::MessageOf([&] { ParseCameraModel("# x", "t.cameramodel"); }),
              ::testing::HasSubstr("t.cameramodel: is not a readable mrcal .cameramodel"));
  const CameraModel m = ParseCameraModel(
      "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [ 1000, 1000, 319.5, 239.5 ], # it's a pinhole\n"
      "  'imagersize': [ 640, 480 ], 'extrinsics': [0,0,0,0,0,0] } # no newline after this comment",
      "t.cameramodel");
  EXPECT_EQ(m.lensmodel, "LENSMODEL_PINHOLE");
  EXPECT_EQ(m.width, 640);
}

}  // namespace
}  // namespace curvecheck
