// Synthetic camera tests: the truth is what the photo shows, on exact geometry.
#include "synth/synthetic_camera.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <Eigen/SVD>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/correction.h"
#include "core/test_util.h"
#include "core/screen_geometry.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {
namespace {

using ::curvecheck::testing::EigenNear;

std::filesystem::path Datasets() {
  const char* src = std::getenv("CURVECHECK_SOURCE_DIR");
  return std::filesystem::path(src ? src : ".") / "datasets";
}

std::vector<cv::Point2d> ImagePoints(const nlohmann::json& truth) {
  std::vector<cv::Point2d> out;
  for (const auto& f : truth["features"]) out.emplace_back(f["image_px"][0].get<double>(), f["image_px"][1].get<double>());
  return out;
}

// Largest residual of the homography from `from` to `to`, fitted in double precision (normalized DLT through
// Eigen's SVD; OpenCV's findHomography works in single precision, ~1e-5 px at these coordinates).
double HomographyResidual(const std::vector<cv::Point2d>& from, const std::vector<cv::Point2d>& to) {
  auto normalizer = [](const std::vector<cv::Point2d>& pts) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : pts) mean += Eigen::Vector2d(p.x, p.y);
    mean /= static_cast<double>(pts.size());
    double spread = 0;
    for (const auto& p : pts) spread += (Eigen::Vector2d(p.x, p.y) - mean).norm();
    const double s = std::sqrt(2.0) * static_cast<double>(pts.size()) / spread;
    Eigen::Matrix3d t;
    t << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
    return t;
  };
  const Eigen::Matrix3d ta = normalizer(from), tb = normalizer(to);
  Eigen::MatrixXd a(2 * from.size(), 9);
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d p = ta * Eigen::Vector3d(from[i].x, from[i].y, 1), q = tb * Eigen::Vector3d(to[i].x, to[i].y, 1);
    a.row(static_cast<Eigen::Index>(2 * i)) << p.x(), p.y(), 1, 0, 0, 0, -q.x() * p.x(), -q.x() * p.y(), -q.x();
    a.row(static_cast<Eigen::Index>(2 * i + 1)) << 0, 0, 0, p.x(), p.y(), 1, -q.y() * p.x(), -q.y() * p.y(), -q.y();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  const Eigen::Matrix3d hm = tb.inverse() * hn * ta;
  double worst = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d m = hm * Eigen::Vector3d(from[i].x, from[i].y, 1);
    worst = std::max(worst, (m.hnormalized() - Eigen::Vector2d(to[i].x, to[i].y)).norm());
  }
  return worst;
}

// The precomputed, interpolated rays reproject through mrcal to within 0.001 px (issue 4).
TEST(SyntheticCamera, RayGridInterpolationBelowOneThousandthPixel) {
  const CameraModel cam = ReadCameraModel(Datasets() / "cameras/default-24mp-opencv8.cameramodel");
  const RayGrid grid(cam, 16);
  const double err = grid.MeasureErrorPx(cam, 20000, 3);
  std::cout << "ray grid 16 px, default 24 MP OPENCV8: worst reprojection error " << err << " px\n";
  EXPECT_LT(err, 0.001);
}

// The tracer's row-coherent rays (RowNodes at DenseColumn) are Ray()'s, which MeasureErrorPx checked above.
TEST(SyntheticCamera, RowCoherentRaysEqualPointRays) {
  const CameraModel cam = ScaledCamera(ReadCameraModel(Datasets() / "cameras/default-24mp-opencv8.cameramodel"), 0.2);
  const RayGrid grid(cam, 16);
  std::vector<Eigen::Vector2d> nodes;
  double worst = 0;
  for (double y : {-0.5, -0.375, 0.0, 13.7, 400.25, cam.height - 0.5}) {
    grid.RowNodes(y, &nodes);
    for (double x : {-0.5, -0.125, 3.3, 611.9, cam.width - 0.5}) {
      int i;
      double f;
      grid.DenseColumn(x, &i, &f);
      const Eigen::Vector2d n = (1 - f) * nodes[static_cast<size_t>(i)] + f * nodes[static_cast<size_t>(i) + 1];
      worst = std::max(worst, (Eigen::Vector3d(n.x(), n.y(), 1) - grid.Ray({x, y})).norm());
    }
  }
  EXPECT_LT(worst, 1e-12);
}

// A pinhole camera looking straight at a flat monitor sees the display through an exact homography.
TEST(SyntheticCamera, PinholeOnFlatMonitorIsAnExactHomography) {
  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  s.truth.curvature_per_mm = 0;
  s.camera = PinholeModel(3000, 2000, 3500);
  s.screen_from_cam.translation = {40, -25, 900};
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, {0, 0, 0}, Eigen::Vector3d::UnitY());
  PatternSpec spec;
  spec.cols = 12;
  spec.rows = 7;
  const Pattern p = BuildPattern(spec, s.monitor, s.screen_from_cam.translation, TangentPlaneAtCentre(s.monitor));
  const nlohmann::json truth = TruthJson(s, p.features);
  std::vector<cv::Point2d> display;
  for (const Feature& f : p.features) display.emplace_back(f.display_px->x(), f.display_px->y());
  EXPECT_LT(HomographyResidual(display, ImagePoints(truth)), 1e-6);
}

// A photo from the stated viewpoint of an exact render on an ideal curved monitor is a planar perspective
// image of the pattern plane: in undistorted (normalized) coordinates, a homography of the plane coordinates.
TEST(SyntheticCamera, ExactRenderSeenFromItsViewpointIsPlanarPerspective) {
  const SyntheticScene s = LoadScene(Datasets() / "scenes/off-axis.yaml");
  PatternSpec spec;
  spec.kind = PatternKind::kBoth;
  const Pattern p = BuildPattern(spec, s.monitor, s.screen_from_cam.translation, TangentPlaneAtCentre(s.monitor));
  const nlohmann::json truth = TruthJson(s, p.features);
  std::vector<cv::Point2d> plane, normalized;
  std::vector<Eigen::Vector2d> pixels;
  for (size_t i = 0; i < p.features.size(); ++i) {
    if (!truth["features"][i]["visible"].get<bool>()) continue;
    plane.emplace_back(p.features[i].pattern_mm.x(), p.features[i].pattern_mm.y());
    pixels.emplace_back(truth["features"][i]["image_px"][0].get<double>(), truth["features"][i]["image_px"][1].get<double>());
  }
  ASSERT_GT(plane.size(), 50u);
  for (const Eigen::Vector3d& v : UnprojectPixels(s.camera, pixels)) normalized.emplace_back(v.x() / v.z(), v.y() / v.z());
  const double residual_px = HomographyResidual(plane, normalized) * s.camera.intrinsics[0];
  std::cout << "planar perspective residual: " << residual_px << " px over " << plane.size() << " features\n";
  EXPECT_LT(residual_px, 0.02);
}

// Every scene loads and sees the default pattern; the truth moves with the true geometry where it should.
TEST(SyntheticCamera, ScenesLoadAndTheirTruthFollowsTheTrueGeometry) {
  std::map<std::string, nlohmann::json> truths;
  for (const auto& entry : std::filesystem::directory_iterator(Datasets() / "scenes")) {
    const SyntheticScene s = LoadScene(entry.path());
    PatternSpec spec;
    spec.kind = PatternKind::kAprilTag;
    const Pattern p = BuildPattern(spec, s.monitor, ScreenCentreInScreen(s.monitor) + Eigen::Vector3d(0, 0, 1500),
                                   TangentPlaneAtCentre(s.monitor));
    const nlohmann::json t = TruthJson(s, p.features);
    int visible = 0;
    for (const auto& f : t["features"]) visible += f["visible"].get<bool>() ? 1 : 0;
    // From 1.5 m or farther the camera sees the whole pattern, the phone and the webcam (69-70 deg lenses) from
    // 1.1 m too; from 700 mm (close) the 62 deg lens sees part.
    const bool close = entry.path().stem() == "close";
    std::cout << entry.path().stem() << ": " << visible << "/" << p.features.size() << " features visible\n";
    EXPECT_EQ(visible == static_cast<int>(p.features.size()), !close) << entry.path();
    EXPECT_GT(visible, static_cast<int>(p.features.size()) / 2) << entry.path();
    truths[entry.path().stem().string()] = t;
  }
  ASSERT_EQ(truths.size(), 9u);
  auto shift = [&](const std::string& a, const std::string& b, size_t i) {
    const auto& fa = truths[a]["features"][i]["image_px"];
    const auto& fb = truths[b]["features"][i]["image_px"];
    return std::hypot(fa[0].get<double>() - fb[0].get<double>(), fa[1].get<double>() - fb[1].get<double>());
  };
  const size_t n = truths["default"]["features"].size();
  double bulge_max = 0, radius_max = 0, lean_max = 0;
  for (size_t i = 0; i < n; ++i) {
    bulge_max = std::max(bulge_max, shift("default", "bulge-2mm", i));
    radius_max = std::max(radius_max, shift("default", "radius-8pct", i));
    lean_max = std::max(lean_max, shift("default", "lean-1deg", i));
  }
  std::cout << "max image shift vs the ideal monitor: bulge " << bulge_max << " px, radius +8% " << radius_max
            << " px, lean 1 deg " << lean_max << " px\n";
  EXPECT_GT(bulge_max, 0.5);
  EXPECT_GT(radius_max, 1.0);
  EXPECT_GT(lean_max, 1.0);
}

// In a noise-free, blur-free photo the checkerboard corners are where the truth says, to the precision of a
// sub-pixel corner refinement.
TEST(SyntheticCamera, TruthMatchesCornersInTheRenderedPhoto) {
  SyntheticScene s = LoadScene(Datasets() / "scenes/off-axis.yaml");
  s.monitor = MonitorFromDiagonal("49 1000R half", 2560, 720, 49, 1000);  // same geometry, half resolution
  s.camera.width = 1500;  // a 1500 x 1000 crop-sized camera with the same lens scaled
  s.camera.height = 1000;
  s.camera.intrinsics = {1250, 1250, 749.5, 499.5, -0.05, 0.02, 0.0002, -0.0002, -0.005, 0.001, 0.001, -0.001};
  s.optics = Optics();
  s.optics.supersample = 4;
  s.sensor.noise = false;
  s.display.fill_factor = 1.0;
  s.display.rgb_stripes = false;
  PatternSpec spec;
  spec.cols = 10;
  spec.rows = 4;
  const Pattern p = BuildPattern(spec, s.monitor, s.screen_from_cam.translation, TangentPlaneAtCentre(s.monitor));
  Renderer renderer;
  RenderOptions options;
  options.display_gamma = 1.0;
  const GrayImage shown = renderer.Render(s.monitor, s.screen_from_cam.translation, p, options);
  Image8 display{shown.width, shown.height, 1, shown.pixels};
  s.display.gamma = 1.0;
  const SyntheticPhoto photo = RenderSyntheticPhoto(s, display);
  const nlohmann::json truth = TruthJson(s, p.features);
  const cv::Mat img = PhotoToMat(photo);
  std::vector<cv::Point2f> corners, expected;
  for (const auto& f : truth["features"]) {
    const cv::Point2f t(f["image_px"][0].get<float>(), f["image_px"][1].get<float>());
    expected.push_back(t);
    corners.push_back(t + cv::Point2f(0.8f, -0.6f));  // start off the truth
  }
  cv::cornerSubPix(img, corners, cv::Size(6, 6), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  double sum2 = 0, worst = 0;
  cv::Point2d mean(0, 0);
  for (size_t i = 0; i < corners.size(); ++i) {
    mean += cv::Point2d(corners[i] - expected[i]) / static_cast<double>(corners.size());
    const double e = cv::norm(corners[i] - expected[i]);
    sum2 += e * e;
    worst = std::max(worst, e);
  }
  const double rms = std::sqrt(sum2 / corners.size());
  std::cout << "cornerSubPix vs truth over " << corners.size() << " corners: mean (" << mean.x << ", " << mean.y
            << ") px, rms " << rms << " px, max " << worst
            << " px (rays " << photo.timing.rays << ", trace " << photo.timing.trace_ms << " ms)\n";
  // The truth is unbiased (the mean offset is the test of the truth); the scatter is cornerSubPix's own
  // precision on perspective-distorted corners (~0.1 px here).
  EXPECT_LT(std::hypot(mean.x, mean.y), 0.05);
  EXPECT_LT(rms, 0.15);
  EXPECT_LT(worst, 0.3);
}


// The lean is an axis tilt (TrueMonitor::lean_deg), not a rigid rotation: the top edge's centre moves H/2 sin(l)
// toward the viewer and H/2 (1 - cos(l)) down, every row stays a horizontal arc of the true radius, every column a
// straight segment of length H along (0, cos l, sin l); against a panel rigidly rotated by the same angle the
// points differ by the sagitta: (0, sag(u) sin(l), sag(u) (1 - cos l)), sag(u) = (1 - cos(k u W/2))/k.
TEST(SyntheticCamera, LeanIsAnAxisTiltNotARigidRotation) {
  SyntheticScene s = LoadScene(Datasets() / "scenes/default.yaml");
  s.truth.curvature_per_mm = 1 / 1080.0;  // a true radius other than the nominal 1000 mm
  const double lean = 1.0 * M_PI / 180, k = s.truth.curvature_per_mm, h = s.monitor.height_mm, w = s.monitor.width_mm;
  s.truth.lean_deg = 1.0;
  const Eigen::Vector3d centre = ScreenCentreInScreen(s.monitor);  // no translation: the true centre stays
  EXPECT_THAT(TrueSurfacePointInScreen(s, {0, -1}) - centre,
              EigenNear(Eigen::Vector3d(0, 0.5 * h * std::cos(lean), 0.5 * h * std::sin(lean)), 1e-9));
  EXPECT_THAT(TrueSurfacePointInScreen(s, {0, 1}) - centre,
              EigenNear(Eigen::Vector3d(0, -0.5 * h * std::cos(lean), -0.5 * h * std::sin(lean)), 1e-9));
  Eigen::Vector3d normal;
  TrueSurfacePointInScreen(s, {0, 0}, &normal);
  EXPECT_THAT(normal, EigenNear(Eigen::Vector3d(0, -std::sin(lean), std::cos(lean)), 1e-12));

  SyntheticScene rigid = s;
  rigid.truth.lean_deg = 0;
  rigid.truth.rotation_deg = Eigen::Vector3d(1.0, 0, 0);  // the top toward the viewer, rigidly
  double largest_difference_mm = 0;
  for (double v : {-1.0, -0.4, 0.3, 1.0}) {
    const double y = -0.5 * v * h;
    // The row's arc: centre on the tilted axis at (0, y cos l, R + y sin l) from the screen centre, radius R.
    const Eigen::Vector3d arc_centre = centre + Eigen::Vector3d(0, y * std::cos(lean), 1 / k + y * std::sin(lean));
    for (double u : {-1.0, -0.55, 0.0, 0.2, 0.9, 1.0}) {
      const Eigen::Vector3d p = TrueSurfacePointInScreen(s, {u, v});
      EXPECT_NEAR(p.y() - centre.y(), y * std::cos(lean), 1e-9) << u << " " << v;  // horizontal
      EXPECT_NEAR((p - arc_centre).norm(), 1 / k, 1e-9) << u << " " << v;
      const Eigen::Vector3d column = TrueSurfacePointInScreen(s, {u, -1}) - TrueSurfacePointInScreen(s, {u, 1});
      EXPECT_THAT(column, EigenNear(Eigen::Vector3d(0, h * std::cos(lean), h * std::sin(lean)), 1e-9));
      const double sag = (1 - std::cos(k * u * w / 2)) / k;
      const Eigen::Vector3d expected(0, sag * std::sin(lean), sag * (1 - std::cos(lean)));
      EXPECT_THAT(TrueSurfacePointInScreen(s, {u, v}) - TrueSurfacePointInScreen(rigid, {u, v}),
                  EigenNear(expected, 1e-9));
      largest_difference_mm = std::max(largest_difference_mm, expected.norm());
    }
  }
  // At the side edges of this 49" panel the sagitta is 160 mm: the two differ by 2.8 mm there, so a fit can
  // tell a lean from a camera pose.
  std::cout << "lean vs rigid rotation by 1 deg: up to " << largest_difference_mm << " mm apart\n";
  EXPECT_GT(largest_difference_mm, 2.5);
  const nlohmann::json truth = TruthJson(s, {});
  EXPECT_THAT(truth["true_monitor"]["lean_definition"].get<std::string>(), ::testing::StartsWith("axis tilt"));
}

// A panel whose true pixel pitch is the datasheet's times (1 + d): every row is an arc of the true radius whose
// length is the nominal width times (1 + d), every column the nominal height times (1 + d); truth.json says so.
TEST(SyntheticCamera, PitchScaleScalesThePanelNotItsRadius) {
  SyntheticScene s = LoadScene(Datasets() / "scenes/default.yaml", {"true_monitor.pitch_scale=1.002"});
  EXPECT_EQ(s.truth.pitch_scale, 1.002);
  const double k = s.truth.curvature_per_mm, w = s.monitor.width_mm * 1.002, h = s.monitor.height_mm * 1.002;
  const Eigen::Vector3d centre = ScreenCentreInScreen(s.monitor);
  const Eigen::Vector3d axis = centre + Eigen::Vector3d(0, 0, 1 / k);
  for (double u : {-1.0, 0.5, 1.0}) {
    const Eigen::Vector3d p = TrueSurfacePointInScreen(s, {u, 0});
    EXPECT_NEAR((p - axis).norm(), 1 / k, 1e-9) << u;                                  // the true radius
    EXPECT_NEAR(std::atan2(p.x() - axis.x(), axis.z() - p.z()) / k, 0.5 * u * w, 1e-9) << u;  // arc length
  }
  EXPECT_NEAR((TrueSurfacePointInScreen(s, {0, -1}) - TrueSurfacePointInScreen(s, {0, 1})).norm(), h, 1e-9);
  EXPECT_EQ(TruthJson(s, {})["true_monitor"]["pitch_scale"].get<double>(), 1.002);
  EXPECT_THAT(testing::MessageOf([&] {
                LoadScene(Datasets() / "scenes/default.yaml", {"true_monitor.pitch_scale=1.5"});
              }),
              ::testing::HasSubstr("pitch_scale"));
}

// The ray tracer sees the leaned, bumped surface where the truth puts it: a bump on a leaned panel (the
// deviation along the leaned normal) in a noise-free, blur-free photo, corners checked against the truth.
TEST(SyntheticCamera, LeanedAndBumpedSurfaceInThePhotoMatchesTheTruth) {
  SyntheticScene s = LoadScene(Datasets() / "scenes/default.yaml");
  s.monitor = MonitorFromDiagonal("49 1000R half", 2560, 720, 49, 1000);
  s.truth.curvature_per_mm = 1 / 1000.0;
  s.truth.lean_deg = 3;
  s.truth.bumps = {{0.1, -0.2, 0.3, 0.5, 6.0}};  // 6 mm, wide: every corner moves
  s.camera = ScaledCamera(s.camera, 0.25);
  s.imaging = ImagingFromPreset(ImagingPreset::kClean);  // the geometry in the clean chain
  s.optics = Optics();
  s.optics.supersample = 4;
  s.sensor.noise = false;
  s.display.fill_factor = 1.0;
  s.display.rgb_stripes = false;
  s.display.gamma = 1.0;
  PatternSpec spec;
  spec.cols = 10;
  spec.rows = 4;
  const Pattern p = BuildPattern(spec, s.monitor, s.screen_from_cam.translation, TangentPlaneAtCentre(s.monitor));
  Renderer renderer;
  RenderOptions options;
  options.display_gamma = 1.0;
  const GrayImage shown = renderer.Render(s.monitor, s.screen_from_cam.translation, p, options);
  const SyntheticPhoto photo = RenderSyntheticPhoto(s, Image8{shown.width, shown.height, 1, shown.pixels});
  EXPECT_GT(photo.timing.refined_rays, photo.timing.rays / 4);
  const nlohmann::json truth = TruthJson(s, p.features);
  SyntheticScene flat_panel = s;  // the same without lean and bump: the corners must move measurably
  flat_panel.truth.lean_deg = 0;
  flat_panel.truth.bumps.clear();
  const nlohmann::json ideal = TruthJson(flat_panel, p.features);
  const cv::Mat img = PhotoToMat(photo);
  std::vector<cv::Point2f> corners;
  std::vector<cv::Point2d> expected;
  double moved_max = 0;
  for (size_t i = 0; i < truth["features"].size(); ++i) {
    const auto& f = truth["features"][i];
    const cv::Point2d t(f["image_px"][0].get<double>(), f["image_px"][1].get<double>());
    const cv::Point2d t0(ideal["features"][i]["image_px"][0].get<double>(), ideal["features"][i]["image_px"][1].get<double>());
    moved_max = std::max(moved_max, cv::norm(t - t0));
    expected.push_back(t);
    corners.emplace_back(static_cast<float>(t.x + 0.8), static_cast<float>(t.y - 0.6));
  }
  cv::cornerSubPix(img, corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  cv::Point2d mean(0, 0);
  double sum2 = 0;
  for (size_t i = 0; i < corners.size(); ++i) {
    const cv::Point2d e = cv::Point2d(corners[i]) - expected[i];
    mean += e / static_cast<double>(corners.size());
    sum2 += e.dot(e);
  }
  const double rms = std::sqrt(sum2 / static_cast<double>(corners.size()));
  std::cout << "leaned 3 deg + 6 mm bump, 1500 x 1000 px: corners moved up to " << moved_max << " px; cornerSubPix vs "
            << "truth mean (" << mean.x << ", " << mean.y << ") px, rms " << rms << " px; "
            << photo.timing.refined_rays << " of " << photo.timing.rays << " rays refined\n";
  EXPECT_GT(moved_max, 0.5);
  EXPECT_LT(std::hypot(mean.x, mean.y), 0.05);
  EXPECT_LT(rms, 0.15);
}

// The sensor's Poisson-Gaussian noise has the variance of its model: e + read^2 electrons above 20 e (Gaussian),
// Poisson(e) + read noise below; the mean is the exposure. A uniform grey display filling a pinhole camera's view.
TEST(SyntheticCamera, SensorNoiseHasTheModelsMeanAndVariance) {
  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  s.truth.curvature_per_mm = 0;
  s.camera = PinholeModel(300, 300, 1000);  // 270 mm of the screen at 900 mm
  s.screen_from_cam.translation = {0, 0, 900};
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, {0, 0, 0}, Eigen::Vector3d::UnitY());
  s.display.fill_factor = 1;
  s.display.rgb_stripes = false;
  s.display.black = 0;
  s.display.gamma = 1;
  s.optics.supersample = 1;
  s.sensor.bits = 16;
  s.sensor.read_noise_e = 3;
  const Image8 grey{2560, 1440, 1, std::vector<uint8_t>(2560 * 1440, 51)};  // radiance 0.2
  for (const double electrons : {4000.0, 8.0}) {
    s.optics.exposure = electrons / (0.2 * s.sensor.full_well_e);
    const SyntheticPhoto photo = RenderSyntheticPhoto(s, grey);
    double sum = 0, sum2 = 0;
    for (auto it = photo.image.begin<uint16_t>(); it != photo.image.end<uint16_t>(); ++it) {
      const uint16_t c = *it;
      const double e = c / 65535.0 * s.sensor.full_well_e;
      sum += e;
      sum2 += e * e;
    }
    const double n = static_cast<double>(photo.image.total());
    const double mean = sum / n, variance = sum2 / n - mean * mean;
    const double expected_variance = electrons + 9 + s.sensor.full_well_e * s.sensor.full_well_e / (12 * 65535.0 * 65535.0);
    std::cout << electrons << " e: mean " << mean << " e, variance " << variance << " e^2 (model " << expected_variance
              << ")\n";
    // 90000 pixels: the mean to 0.015 e (low) / 0.2 e (high), the variance to ~0.5% (3 sigma: 1.5%). At 8 e the
    // clamp at zero (1.9 sigma below the mean) raises the mean by ~0.05 e and trims the variance by ~3%. (Rows
    // seeded as shifted copies of one stream failed this test: mean off by 10 sigma.)
    EXPECT_NEAR(mean, electrons, electrons > 20 ? 0.7 : 0.1);
    EXPECT_NEAR(variance / expected_variance, 1.0, electrons > 20 ? 0.02 : 0.06);
  }
}
}  // namespace
}  // namespace curvecheck

namespace curvecheck {
namespace {

// optics.sampling: footprint integrates the display's emitters over each sample (a white screen of fill 0.7 is
// even), point takes the light at each ray's hit (the emitters, finer than a sample, alias into a texture: the
// stress condition of an independent ray tracer without footprints). Clean chain, no noise, no blur.
TEST(SyntheticCamera, PointSamplingAliasesTheEmittersAndFootprintsDoNot) {
  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  s.truth.curvature_per_mm = 0;
  s.camera = PinholeModel(300, 300, 1000);  // 0.9 mm per camera px at 900 mm: 3.85 display px of 0.2335 mm
  s.screen_from_cam.translation = {0, 0, 900};
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, {0, 0, 0}, Eigen::Vector3d::UnitY());
  s.display.fill_factor = 0.7;
  s.display.rgb_stripes = true;
  s.display.gamma = 1;
  s.optics.blur = Blur::kNone;
  s.optics.supersample = 2;
  s.sensor.noise = false;
  s.sensor.bits = 16;
  const Image8 white{2560, 1440, 1, std::vector<uint8_t>(2560 * 1440, 255)};
  const auto relative_sd = [&](Sampling sampling) {
    s.optics.sampling = sampling;
    const cv::Mat centre = RenderSyntheticPhoto(s, white).image(cv::Rect(50, 50, 200, 200));
    cv::Scalar mean, sd;
    cv::meanStdDev(centre, mean, sd);
    return sd[0] / mean[0];
  };
  const double footprint = relative_sd(Sampling::kFootprint), point = relative_sd(Sampling::kPoint);
  std::cout << "white screen, fill 0.7, pixel-to-pixel sd / mean: footprint " << footprint << ", point " << point << "\n";
  // Measured 0.042 and 1.05. Footprint: a sample's box is 1.9 display px wide, not a whole number of them, so
  // its lit fraction varies by a few percent (what a pixel aperture without a lens's blur does). Point: each of
  // the 4 samples of a px is lit (a stripe's emitter, its colour's light x 3) or dark.
  EXPECT_LT(footprint, 0.1);
  EXPECT_GT(point, 0.5);
  const std::filesystem::path scene = Datasets() / "scenes/default.yaml";
  EXPECT_EQ(LoadScene(scene, {"optics.sampling=point"}).optics.sampling, Sampling::kPoint);
  EXPECT_EQ(LoadScene(scene).optics.sampling, Sampling::kFootprint);
  EXPECT_THAT(testing::MessageOf([&] { LoadScene(scene, {"optics.sampling=area"}); }),
              ::testing::HasSubstr("key 'optics.sampling' is not one of footprint, point"));
}

TEST(SyntheticCamera, SeedMustBeAWholeNumber) {
  const std::filesystem::path scenes = std::filesystem::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "datasets/scenes";
  EXPECT_EQ(LoadScene(scenes / "default.yaml", {"sensor.seed=12345"}).sensor.seed, 12345u);
  for (const char* bad : {"sensor.seed=-1", "sensor.seed=1e30", "sensor.seed=2.5"}) {
    EXPECT_THAT(testing::MessageOf([&] { LoadScene(scenes / "default.yaml", {bad}); }),
                ::testing::HasSubstr("give a whole number from 0 to 2^53"))
        << bad;
  }
}

// The scene reader names a mistyped key (here from an override) with its path and the keys it knows.
TEST(SceneReader, UnknownKeyIsNamed) {
  const std::filesystem::path scene = Datasets() / "scenes/default.yaml";
  const std::string message = testing::MessageOf([&] { LoadScene(scene, {"optics.blurr=none"}); });
  EXPECT_THAT(message, ::testing::HasSubstr("'optics.blurr' is not a known key"));
  EXPECT_THAT(message, ::testing::HasSubstr("blur_px"));
}

// The imager keeps at least kMinScaledImagerPx on its short side (issue 17: --scale 0.0001 wrote a 1 x 1 photo
// that reported every feature visible): 0.016 of 6000 x 4000 px is 96 x 64 px; 0.0158 (63 px) is refused.
TEST(SceneReader, ScaledCameraKeepsAMeasurableSize) {
  const CameraModel cam = ReadCameraModel(Datasets() / "cameras/default-24mp-opencv8.cameramodel");
  ASSERT_EQ(cam.height, 4000);
  const CameraModel small = ScaledCamera(cam, 0.016);
  EXPECT_EQ(small.width, 96);
  EXPECT_EQ(small.height, 64);
  for (double scale : {0.0158, 0.0001}) {
    try {
      ScaledCamera(cam, scale);
      ADD_FAILURE() << "accepted scale " << scale;
    } catch (const Error& e) {
      EXPECT_EQ(e.where(), "--scale");
      EXPECT_THAT(e.problem(), ::testing::HasSubstr("px on its short side")) << scale;
      EXPECT_EQ(e.fix(), "give a scale of at least 0.016");
    }
  }
}

// `--set` overrides: applied before the checks (which name them), or refused with what to write.
TEST(SceneReader, OverridesAreAppliedAndChecked) {
  const std::filesystem::path scene = Datasets() / "scenes/default.yaml";
  const SyntheticScene s = LoadScene(scene, {"true_monitor.radius_mm=flat", "optics.blur=disc", "display.bezel_mm=0"});
  EXPECT_EQ(s.truth.curvature_per_mm, 0.0);
  EXPECT_EQ(s.optics.blur, Blur::kDisc);
  EXPECT_EQ(s.display.bezel_mm, 0.0);
  EXPECT_EQ(s.optics.blur_px, 0.7);  // from the file
  const std::map<std::string, std::string> refused = {
      {"optics", "--set optics: is not KEY=VALUE"},
      {"optics..blur=none", "has an empty key"},
      {"monitor.name=x", "'monitor' is not a mapping"},
      {"optics.blur=[", "has a value that is not YAML"},
      {"optics.blur=box", "default.yaml with optics.blur=box: key 'optics.blur' is not one of none, gaussian, disc"},
      {"optics.blur_px=", "--set optics.blur_px=: has no value after '='; give one, e.g. optics.blur_px=1.5"},
      {"optics.blur_px=~", "--set optics.blur_px=~: has no value after '='"},
      {"optics.blur_px=0x10", "key 'optics.blur_px' must be a decimal number, got '0x10'"},
  };
  for (const auto& [override_text, expected] : refused) {
    EXPECT_THAT(testing::MessageOf([&] { LoadScene(scene, {override_text}); }), ::testing::HasSubstr(expected))
        << override_text;
  }
}

}  // namespace
}  // namespace curvecheck
