// The realistic colour chain, stage by stage (synth/imaging.h, the colour trace of synth/tracer.h) and whole
// (RenderSyntheticPhoto with a preset): each test measures an effect against its analytic expectation.
#include "synth/imaging.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "core/test_util.h"
#include "synth/synthetic_camera.h"
#include "synth/tracer.h"

namespace curvecheck::synth_internal {
namespace {

std::filesystem::path Scenes() {
  const char* src = std::getenv("CURVECHECK_SOURCE_DIR");
  return std::filesystem::path(src ? src : ".") / "datasets/scenes";
}

// The raw chain without noise, PRNU or vignetting: what the DN are is exposure x radiance x (2^bits - 1).
Imaging QuietImaging() {
  Imaging g = ImagingFromPreset(ImagingPreset::kIlc24);
  g.prnu = 0;
  g.vignetting_ev = 0;
  g.exposure = 1;
  g.raw_bits = 12;
  g.tone = ToneCurve::kLinear;
  return g;
}
Sensor Quiet() {
  Sensor s;
  s.noise = false;
  return s;
}

// RGGB mosaic and OpenCV's Bayer code agree: a uniform colour comes back as itself from every demosaic (a
// wrong code would swap R and B or mix G in).
TEST(ImagingChain, BayerMosaicAndDemosaicKeepAUniformColour) {
  const cv::Mat radiance(64, 64, CV_32FC3, cv::Scalar(0.1, 0.3, 0.6));  // B, G, R
  for (const Demosaic d : {Demosaic::kBilinear, Demosaic::kVng, Demosaic::kEdgeAware}) {
    Imaging g = QuietImaging();
    g.demosaic = d;
    const cv::Mat raw = ExposeRaw(g, Quiet(), radiance);
    ASSERT_EQ(raw.type(), CV_16U);
    EXPECT_EQ(raw.at<uint16_t>(10, 10), std::lround(0.6 * 4095));  // R at even row, even column
    EXPECT_EQ(raw.at<uint16_t>(10, 11), std::lround(0.3 * 4095));
    EXPECT_EQ(raw.at<uint16_t>(11, 11), std::lround(0.1 * 4095));  // B at odd, odd
    const cv::Mat out = ToneMap8(DemosaicRaw(raw, g), g.raw_bits, g.tone);
    const cv::Scalar mean = cv::mean(out(cv::Rect(8, 8, 48, 48)));
    EXPECT_NEAR(mean[0], 0.1 * 255, 1.5) << static_cast<int>(d);
    EXPECT_NEAR(mean[1], 0.3 * 255, 1.5) << static_cast<int>(d);
    EXPECT_NEAR(mean[2], 0.6 * 255, 1.5) << static_cast<int>(d);
  }
}

// Electrons per raw site: variance e + read^2 (shot + read noise) on top of the PRNU's (prnu e)^2, which is fixed
// per seed: the same seed gives the same pattern, noise off shows it alone.
TEST(ImagingChain, RawNoiseIsShotReadAndFixedPrnu) {
  const cv::Mat radiance(400, 400, CV_32FC3, cv::Scalar::all(0.5));
  Imaging g = QuietImaging();
  g.raw_bits = 16;
  g.full_well_e = 20000;
  g.read_noise_e = 5;
  const double dn_per_e = 65535.0 / g.full_well_e, e = 0.5 * g.full_well_e;
  const auto variance_e2 = [&](const cv::Mat& raw) {
    cv::Scalar mean, sd;
    cv::meanStdDev(raw, mean, sd);
    return std::pow(sd[0] / dn_per_e, 2);
  };
  Sensor noisy;
  noisy.seed = 7;
  const double shot_read = variance_e2(ExposeRaw(g, noisy, radiance));
  EXPECT_NEAR(shot_read / (e + 25), 1.0, 0.02);  // 160000 sites: the variance to 0.35% (1 sigma)
  g.prnu = 0.007;
  const double prnu_alone = variance_e2(ExposeRaw(g, Quiet(), radiance));
  EXPECT_NEAR(std::sqrt(prnu_alone) / e, 0.007, 0.0002);
  const double all = variance_e2(ExposeRaw(g, noisy, radiance));
  EXPECT_NEAR(all / (e + 25 + std::pow(0.007 * e, 2)), 1.0, 0.02);
  Sensor quiet7 = Quiet();
  quiet7.seed = 7;
  EXPECT_EQ(cv::norm(ExposeRaw(g, quiet7, radiance), ExposeRaw(g, quiet7, radiance), cv::NORM_INF), 0);
  Sensor quiet8 = quiet7;
  quiet8.seed = 8;
  EXPECT_GT(cv::norm(ExposeRaw(g, quiet7, radiance), ExposeRaw(g, quiet8, radiance), cv::NORM_INF), 10);
  std::cout << "raw noise: shot+read " << shot_read << " e^2 (model " << e + 25 << "), PRNU alone "
            << std::sqrt(prnu_alone) / e << " of the signal\n";
}

// Exposure above 1 clips whites at the full well (the raw's largest DN, 255 after the tone curve) and leaves
// greys below it on the sRGB curve.
TEST(ImagingChain, ExposureAboveOneClipsWhites) {
  cv::Mat radiance(32, 64, CV_32FC3, cv::Scalar::all(1.0));
  radiance(cv::Rect(32, 0, 32, 32)).setTo(cv::Scalar::all(0.25));
  Imaging g = QuietImaging();
  g.tone = ToneCurve::kSrgb;
  g.exposure = 1.6;
  const cv::Mat raw = ExposeRaw(g, Quiet(), radiance);
  double lo, hi;
  cv::minMaxLoc(raw(cv::Rect(0, 0, 32, 32)), &lo, &hi);
  EXPECT_EQ(lo, 4095);  // every white site clipped
  const cv::Mat out = ToneMap8(DemosaicRaw(raw, g), g.raw_bits, g.tone);
  EXPECT_EQ(cv::mean(out(cv::Rect(4, 4, 24, 24)))[1], 255);
  const double grey = 1.055 * std::pow(0.4, 1 / 2.4) - 0.055;  // 0.25 x 1.6 on the sRGB curve
  EXPECT_NEAR(cv::mean(out(cv::Rect(36, 4, 24, 24)))[1], grey * 255, 1.0);
}

// Vignetting: the gain at the corner is 2^-EV for both models; cos4 at half the corner distance follows
// (1 + a r^2)^-2 with a = 2^(EV/2) - 1; the raw's corner over centre shows it.
TEST(ImagingChain, VignettingLosesTheGivenStopsAtTheCorner) {
  for (const VignettingModel m : {VignettingModel::kCos4, VignettingModel::kQuadratic}) {
    EXPECT_NEAR(VignettingGain(m, 1.0, 1.0), 0.5, 1e-12);
    EXPECT_NEAR(VignettingGain(m, 0.0, 1.0), 1.0, 1e-12);
    EXPECT_NEAR(VignettingGain(m, 1.0, 0.0), 1.0, 1e-12);
  }
  EXPECT_NEAR(VignettingGain(VignettingModel::kQuadratic, 1.0, 0.5), 0.875, 1e-12);
  EXPECT_NEAR(VignettingGain(VignettingModel::kCos4, 1.0, 0.5), 1 / std::pow(1 + (std::sqrt(2.0) - 1) / 4, 2), 1e-12);
  Imaging g = QuietImaging();
  g.vignetting_ev = 1.5;
  g.cfa = ColourFilter::kNone;
  const cv::Mat raw = ExposeRaw(g, Quiet(), cv::Mat(101, 151, CV_32FC3, cv::Scalar::all(0.8)));
  EXPECT_NEAR(raw.at<cv::Vec3w>(0, 0)[1] / static_cast<double>(raw.at<cv::Vec3w>(50, 75)[1]), std::exp2(-1.5), 1e-3);
}

// Thin-lens defocus against the formula worked by hand: f = 20 mm, f/4, focused at 1500 mm, a point at
// 1000 mm: c = 20^2 / 4 x 500 / (1000 x 1480) = 0.033784 mm, sigma = c / 4 = 2.111 px of 4 um. In focus: 0.
TEST(ImagingChain, DefocusIsTheThinLensCircleOfConfusion) {
  EXPECT_NEAR(DefocusSigmaPx(1000, 1500, 20, 4, 4), 0.033784 / 4 / 0.004, 1e-3);
  EXPECT_NEAR(DefocusSigmaPx(1500, 1500, 20, 4, 4), 0, 1e-12);
  EXPECT_NEAR(DefocusSigmaPx(1000, 1500, 20, 8, 4), 0.5 * DefocusSigmaPx(1000, 1500, 20, 4, 4), 1e-12);
  EXPECT_EQ(DefocusSigmaPx(1000, 1500, 20, 0, 4), 0);      // pinhole
  EXPECT_EQ(DefocusSigmaPx(NAN, 1500, 20, 4, 4), 0);       // the room
}

// The per-pixel blur: a vertical edge blurred with sigma 0.8 px in the top band, 1.3 (between two levels) in the
// middle and 2.5 at the bottom; each band's edge profile has the variance of its sigma (the derivative's
// second moment).
TEST(ImagingChain, DepthBlurGivesEachPixelItsSigma) {
  cv::Mat image(300, 200, CV_32F, cv::Scalar(0.1f));
  image.colRange(100, 200).setTo(0.9f);
  cv::Mat sigma(300, 200, CV_32F);
  const double sigmas[3] = {0.8, 1.3, 2.5};
  for (int band = 0; band < 3; ++band) sigma.rowRange(band * 100, band * 100 + 100).setTo(sigmas[band]);
  const int levels = BlurBySigmaMap(sigma, &image);
  EXPECT_GE(levels, 3);
  for (int band = 0; band < 3; ++band) {
    const int y = band * 100 + 50;
    double sum = 0, sum_x = 0, sum_x2 = 0;
    for (int x = 80; x < 120; ++x) {
      const double d = image.at<float>(y, x + 1) - image.at<float>(y, x);  // at x + 0.5
      sum += d;
      sum_x += d * (x + 0.5);
      sum_x2 += d * (x + 0.5) * (x + 0.5);
    }
    const double mean = sum_x / sum, variance = sum_x2 / sum - mean * mean;
    // The step is a sampled one (between pixels 99 and 100), so the blurred step's differences are the kernel's
    // samples themselves: their variance is the PSF's, with no pixel box added.
    const double measured = std::sqrt(variance);
    std::cout << "sigma " << sigmas[band] << " px: measured " << measured << " px, edge at " << mean << "\n";
    EXPECT_NEAR(measured, sigmas[band], 0.02 * sigmas[band]);
    EXPECT_NEAR(mean, 99.5, 1e-3);  // the symmetric PSF keeps the edge where it is
  }
}

// Veiling glare adds its fraction of the mean radiance everywhere: 10% of the frame at 1, glare 2% -> +0.002.
TEST(ImagingChain, VeilingGlareAddsAFractionOfTheMean) {
  cv::Mat image(100, 100, CV_32FC3, cv::Scalar::all(0));
  image(cv::Rect(0, 0, 10, 100)).setTo(cv::Scalar::all(1));
  AddVeilingGlare(0.02, &image);
  EXPECT_NEAR(image.at<cv::Vec3f>(50, 50)[1], 0.002, 1e-6);
  EXPECT_NEAR(image.at<cv::Vec3f>(50, 5)[1], 1.002, 1e-6);
}

// JPEG: more quality, less error; 4:2:0 chroma subsampling (the luma component's sampling factors 2 x 2 in
// the frame header).
TEST(ImagingChain, JpegIsLossyAndSubsamplesChroma) {
  cv::Mat image(256, 256, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::GaussianBlur(image, image, cv::Size(0, 0), 1.5);
  double previous = 1e9;
  for (const int q : {50, 85, 95}) {
    const std::vector<uint8_t> jpeg = EncodeJpeg(image, q);
    const double rms = cv::norm(DecodeJpeg(jpeg), image, cv::NORM_L2) / std::sqrt(image.total() * 3.0);
    std::cout << "JPEG q" << q << ": " << jpeg.size() << " bytes, RMS error " << rms << " code values\n";
    EXPECT_LT(rms, previous);
    EXPECT_GT(rms, 0.1);
    previous = rms;
    // SOF0 (FF C0): length, precision, height, width, components, then id 1 (Y) with its sampling factors.
    size_t sof = 0;
    while (sof + 1 < jpeg.size() && !(jpeg[sof] == 0xFF && jpeg[sof + 1] == 0xC0)) ++sof;
    ASSERT_LT(sof + 12, jpeg.size());
    EXPECT_EQ(jpeg[sof + 9], 3);      // Y, Cb, Cr
    EXPECT_EQ(jpeg[sof + 11], 0x22);  // Y sampled 2 x 2 against chroma 1 x 1: 4:2:0
    EXPECT_EQ(jpeg[sof + 14], 0x11);
  }
}

// The display's colour seen by a colour sensor: each stripe in its own channel at 3x (white stays 1 per
// channel); the layout puts R or B first; the area average over a whole pixel is its mean on both paths.
TEST(ImagingChain, DisplayStripesLandInTheirChannels) {
  Image8 image{4, 3, 3, std::vector<uint8_t>(4 * 3 * 3, 255)};
  for (const bool bgr : {false, true}) {
    DisplayModel model;
    model.fill_factor = 0.7;
    model.black = 0;
    model.stripes_bgr = bgr;
    const DisplayLight light(model, image, 3);
    const Light<3> first = light.ShadePointN<3>(1 + 0.5 / 3, 1.5);  // R, G, B
    EXPECT_FLOAT_EQ(first[bgr ? 2 : 0], 3.0f);
    EXPECT_FLOAT_EQ(first[1], 0.0f);
    EXPECT_FLOAT_EQ(first[bgr ? 0 : 2], 0.0f);
    for (const double psf : {0.0, 1.0}) {
      const Light<3> whole = light.ShadeAreaN<3>(1.5, 1.5, 1, 1, psf, psf);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(whole[static_cast<size_t>(c)], 0.49, 1e-5) << bgr << psf;
    }
  }
}

// Viewing-angle fall-off and the reflection, in the colour trace: a white flat-fill display on the default
// 1000R monitor seen from 700 mm, 400 mm off axis, through a pinhole. At each probed pixel the IPS / none ratio
// is the table at the angle between that pixel's ray and the cylinder's normal, found here from the geometry
// alone (the ray against the circle of the screen's cross-section).
TEST(ImagingChain, PanelLuminanceFollowsTheViewingAngle) {
  EXPECT_NEAR(PanelLuminance(PanelAngular::kIps, 30), 0.85, 1e-12);
  EXPECT_NEAR(PanelLuminance(PanelAngular::kIps, 37.5), 0.775, 1e-12);
  EXPECT_NEAR(PanelLuminance(PanelAngular::kVa, 60), 0.30, 1e-12);
  EXPECT_NEAR(PanelLuminance(PanelAngular::kOled, 52.5), 0.725, 1e-12);
  EXPECT_EQ(PanelLuminance(PanelAngular::kNone, 70), 1.0);

  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("49 1000R quarter", 1280, 360, 49, 1000);
  s.truth.curvature_per_mm = s.monitor.curvature_per_mm;
  s.camera = PinholeModel(400, 100, 300);
  const Eigen::Vector3d centre = ScreenCentreInScreen(s.monitor);
  const Eigen::Vector3d eye = centre + Eigen::Vector3d(-400, 0, 700);
  s.screen_from_cam = ScreenFromCamLookAt(eye, centre, Eigen::Vector3d::UnitY());
  s.optics.supersample = 1;
  s.display.fill_factor = 1;
  s.display.rgb_stripes = false;
  s.display.black = 0;
  s.imaging = ImagingFromPreset(ImagingPreset::kIlc24);
  s.imaging.blur_px = 0;
  const Image8 white{1280, 360, 1, std::vector<uint8_t>(1280 * 360, 255)};
  const RayGrid rays(s.camera, 16);
  s.imaging.panel = PanelAngular::kNone;
  const ColourTrace none = TraceColour(s, white, rays);
  s.imaging.panel = PanelAngular::kIps;
  const ColourTrace ips = TraceColour(s, white, rays);
  const Eigen::Matrix3d r = s.screen_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d axis = centre + Eigen::Vector3d(0, 0, 1000);  // the cylinder's axis (x, z)
  int probed = 0;
  for (int x = 10; x < 400; x += 20) {
    const int y = 50;
    if (none.radiance.at<cv::Vec3f>(y, x)[1] < 0.99f) continue;  // not on the display
    const Eigen::Vector3d d = r * Eigen::Vector3d((x - 199.5) / 300, (y - 49.5) / 300, 1);
    // |eye + t d - axis| = R in x, z; the far root (the concave side faces the eye).
    const Eigen::Vector2d o(eye.x() - axis.x(), eye.z() - axis.z()), dd(d.x(), d.z());
    const double a = dd.squaredNorm(), b = 2 * o.dot(dd), c = o.squaredNorm() - 1e6;
    const double t = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
    const Eigen::Vector2d n = -(o + t * dd) / 1000;
    const double angle_deg = std::acos(std::abs(n.dot(dd)) / d.norm()) * 180 / M_PI;
    const double ratio = ips.radiance.at<cv::Vec3f>(y, x)[1] / none.radiance.at<cv::Vec3f>(y, x)[1];
    EXPECT_NEAR(ratio, PanelLuminance(PanelAngular::kIps, angle_deg), 2e-3) << x << " at " << angle_deg << " deg";
    // The depth is the hit's distance along the optical axis.
    const Eigen::Vector3d hit = eye + t * d;
    EXPECT_NEAR(ips.depth_mm.at<float>(y, x), (r.transpose() * (hit - eye)).z(), 0.01 * t) << x;
    ++probed;
  }
  EXPECT_GT(probed, 10);

  // A reflection of 0.5 at u = 0.2 on a black display: the brightest pixel sees 0.5 there.
  s.imaging.panel = PanelAngular::kNone;
  s.imaging.reflection = {0.2, 0.0, 60.0, 0.5};
  const Image8 black{1280, 360, 1, std::vector<uint8_t>(1280 * 360, 0)};
  const ColourTrace lit = TraceColour(s, black, rays);
  double hi;
  cv::Point at;
  std::vector<cv::Mat> planes;
  cv::split(lit.radiance, planes);
  cv::minMaxLoc(planes[1], nullptr, &hi, nullptr, &at);
  EXPECT_NEAR(hi, 0.5, 0.01);
  const Eigen::Vector3d d = r * Eigen::Vector3d((at.x - 199.5) / 300, (at.y - 49.5) / 300, 1);
  const Eigen::Vector2d o(eye.x() - axis.x(), eye.z() - axis.z()), dd(d.x(), d.z());
  const double a = dd.squaredNorm(), b = 2 * o.dot(dd), c = o.squaredNorm() - 1e6;
  const Eigen::Vector2d p = o + (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a) * dd;  // from the axis
  const double u = 1000 * std::atan2(p.x(), -p.y()) / (0.5 * s.monitor.width_mm);
  EXPECT_NEAR(u, 0.2, 0.01);
  EXPECT_LT(planes[1].at<float>(50, 5), 1e-3);  // far from it: black
}

// The presets carry cameras.md's numbers, and a scene's imaging keys override them (also through --set).
TEST(ImagingChain, PresetsAndOverrides) {
  const Imaging phone = ImagingFromPreset(ImagingPreset::kPhone);
  EXPECT_EQ(phone.f_number, 1.8);
  EXPECT_EQ(phone.full_well_e, 12000);
  EXPECT_EQ(phone.raw_bits, 10);
  EXPECT_EQ(phone.jpeg_quality, 95);
  const Imaging webcam = ImagingFromPreset(ImagingPreset::kWebcam);
  EXPECT_EQ(webcam.demosaic, Demosaic::kBilinear);
  EXPECT_EQ(webcam.jpeg_quality, 85);
  const SyntheticScene d = LoadScene(Scenes() / "default.yaml");
  EXPECT_EQ(d.imaging.preset, ImagingPreset::kIlc24);
  EXPECT_EQ(LoadScene(Scenes() / "default.yaml", {"imaging.preset=clean"}).imaging.preset, ImagingPreset::kClean);
  const SyntheticScene q = LoadScene(Scenes() / "default.yaml", {"imaging.jpeg_quality=80", "imaging.panel=va"});
  EXPECT_EQ(q.imaging.jpeg_quality, 80);
  EXPECT_EQ(q.imaging.panel, PanelAngular::kVa);
  EXPECT_EQ(q.imaging.raw_bits, 14);  // the rest from ilc24
  const SyntheticScene w = LoadScene(Scenes() / "default.yaml", {"imaging.preset=webcam", "imaging.raw_bits=10"});
  EXPECT_EQ(w.imaging.raw_bits, 10);
  EXPECT_EQ(w.imaging.full_well_e, 8000);
  EXPECT_EQ(LoadScene(Scenes() / "default.yaml", {"imaging.jpeg_quality=0"}).imaging.jpeg_quality, 0);
  EXPECT_EQ(LoadScene(Scenes() / "default.yaml", {"imaging.jpeg_quality=off"}).imaging.jpeg_quality, 0);
  EXPECT_THAT(curvecheck::testing::MessageOf([&] { LoadScene(Scenes() / "default.yaml", {"imaging.preset=dslr"}); }),
              ::testing::HasSubstr("is not one of clean, phone, ilc24, webcam"));
  EXPECT_THAT(curvecheck::testing::MessageOf([&] { LoadScene(Scenes() / "default.yaml", {"imaging.raw_bits=20"}); }),
              ::testing::HasSubstr("raw_bits"));
  EXPECT_THAT(curvecheck::testing::MessageOf([&] { LoadScene(Scenes() / "default.yaml", {"imaging.jpeg_quality=101"}); }),
              ::testing::HasSubstr("give a whole number 1..100"));
}

// The whole chain: a colour 8-bit photo; PhotoToMat is the gray that ReadPhotoGray would make of the written
// PNG (cvtColor BGR2GRAY), the PNG holds the JPEG-decoded pixels, and a .jpg path gets the JPEG itself.
TEST(ImagingChain, ColourPhotoIsWrittenAndReadAlike) {
  SyntheticScene s = LoadScene(Scenes() / "default.yaml");
  s.camera = ScaledCamera(s.camera, 0.1);
  Image8 display{s.monitor.width_px, s.monitor.height_px, 1, {}};
  display.pixels.resize(static_cast<size_t>(display.width) * display.height);
  for (int y = 0; y < display.height; ++y) {
    for (int x = 0; x < display.width; ++x) {
      display.pixels[static_cast<size_t>(y) * display.width + x] = ((x / 320 + y / 320) % 2) ? 230 : 20;
    }
  }
  const SyntheticPhoto photo = RenderSyntheticPhoto(s, display);
  ASSERT_EQ(photo.channels, 3);
  ASSERT_EQ(photo.bits, 8);
  ASSERT_FALSE(photo.jpeg.empty());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "curvecheck_imaging_test";
  std::filesystem::create_directories(dir);
  WriteSyntheticPhoto(dir / "p.png", photo);
  WriteSyntheticPhoto(dir / "p.jpg", photo);
  const cv::Mat png = cv::imread((dir / "p.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::norm(png, PhotoToStoredMat(photo), cv::NORM_INF), 0);
  cv::Mat gray;
  cv::cvtColor(png, gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(gray, PhotoToMat(photo), cv::NORM_INF), 0);
  EXPECT_EQ(ReadFileToString(dir / "p.jpg"), std::string(photo.jpeg.begin(), photo.jpeg.end()));
  EXPECT_EQ(cv::norm(cv::imread((dir / "p.jpg").string(), cv::IMREAD_UNCHANGED), png, cv::NORM_INF), 0);
  std::filesystem::remove_all(dir);
  // The clean chain writes no JPEG.
  s.imaging = Imaging();
  EXPECT_THAT(curvecheck::testing::MessageOf([&] { WriteSyntheticPhoto(dir / "c.jpg", RenderSyntheticPhoto(s, display)); }),
              ::testing::HasSubstr("has no JPEG"));
}

}  // namespace
}  // namespace curvecheck::synth_internal
