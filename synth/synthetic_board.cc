#include "synth/synthetic_board.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <random>

#include "synth/synthetic_camera.h"
#include "core/error.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"
#include "pattern/pattern.h"

namespace curvecheck {
namespace {


// Display image: one white square of margin around a (corners_x + 1) x (corners_y + 1) checkerboard whose top
// left square is black.
Image8 DrawBoard(const SyntheticBoardOptions& o, int width_px, int height_px) {
  Image8 img;
  img.width = width_px;
  img.height = height_px;
  img.channels = 1;
  img.pixels.assign(static_cast<size_t>(width_px) * height_px, 255);
  const int s = o.square_display_px;
  for (int y = s; y < height_px - s; ++y) {
    for (int x = s; x < width_px - s; ++x) {
      const bool black = (((x - s) / s) + ((y - s) / s)) % 2 == 0;
      if (black) img.pixels[static_cast<size_t>(y) * width_px + x] = 0;
    }
  }
  return img;
}

}  // namespace

void SyntheticBoardOptions::Check() const {
  camera.Check("SyntheticBoardOptions.camera");
  if (views < 1 || corners_x < 2 || corners_y < 2 || square_display_px < 4 || !(pixel_pitch_mm > 0) ||
      !(max_tilt_deg >= 0 && max_tilt_deg < 80) || !(fill_near > fill_far && fill_far > 0 && fill_near < 1.5) ||
      supersample < 1 || !(blur_px >= 0)) {
    throw Error("SyntheticBoardOptions", "a field is out of range", "see synthetic_board.h");
  }
}

SyntheticBoardSet MakeSyntheticBoardSet(const SyntheticBoardOptions& o) {
  o.Check();
  SyntheticBoardSet set;
  const int s = o.square_display_px;
  const int width_px = (o.corners_x + 3) * s, height_px = (o.corners_y + 3) * s;
  set.monitor = MonitorFromActiveArea("synthetic flat target", width_px, height_px, width_px * o.pixel_pitch_mm,
                                      height_px * o.pixel_pitch_mm, 0);
  set.board.corners_x = o.corners_x;
  set.board.corners_y = o.corners_y;
  set.board.square_mm = s * o.pixel_pitch_mm;
  set.board.source = "synthetic";
  const Image8 display = DrawBoard(o, width_px, height_px);

  // Corners: on the display between pixels, so at (2 + c) s - 0.5 (pixel centres at integers); the extended
  // grid (one and a half squares further out) is what must stay in the image.
  std::vector<Feature> corners, outline;
  for (int r = -1; r <= o.corners_y; ++r) {
    for (int c = -1; c <= o.corners_x; ++c) {
      const bool inner = r >= 0 && c >= 0 && r < o.corners_y && c < o.corners_x;
      // Outline points (the extended grid) sit half a square into the white surround.
      const auto at = [s](int i, int n) { return (2 + i) * s - 0.5 + (i < 0 ? -0.5 * s : i >= n ? 0.5 * s : 0.0); };
      const Eigen::Vector2d px(at(c, o.corners_x), at(r, o.corners_y));
      Feature f;
      f.kind = "corner";
      f.display_px = px;
      f.point_in_screen = SurfacePointFromUv(set.monitor, UvFromDisplayPx(set.monitor, px));
      f.visible = true;
      if (inner) {
        f.id = fmt::format("c{}", r * o.corners_x + c);
        corners.push_back(f);
        set.corners_in_screen.push_back(f.point_in_screen);
      } else {
        f.id = fmt::format("c{}", corners.size() + outline.size() + 100000);
        outline.push_back(f);
      }
    }
  }

  SyntheticScene scene;
  scene.monitor = set.monitor;
  scene.camera = o.camera;
  // Emitting over the whole pixel, no RGB stripes: at these scales a display pixel is smaller than a camera
  // pixel, and the pixel grid would alias into moire that biases corners by ~0.5 px (a real lens blurs it away).
  scene.display.rgb_stripes = false;
  scene.display.fill_factor = 1.0;
  scene.optics.supersample = o.supersample;
  scene.optics.blur = o.blur_px > 0 ? Blur::kGaussian : Blur::kNone;
  scene.optics.blur_px = o.blur_px;
  scene.sensor.noise = o.noise;
  scene.imaging = o.imaging;
  const double fx = o.camera.intrinsics[0];
  const double board_mm = (o.corners_x + 1) * set.board.square_mm, board_h_mm = (o.corners_y + 1) * set.board.square_mm;
  const int w = o.camera.width, h = o.camera.height;
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uni(-1, 1), unit(0, 1);

  for (int k = 0; k < o.views; ++k) {
    // Nine target regions (3x3 over the imager, out to its edges) in turn; near and far alternate within them.
    const double tx = ((k % 3) - 1) * 0.42 * w, ty = (((k / 3) % 3) - 1) * 0.42 * h;
    bool placed = false;
    for (int attempt = 0; attempt < 400 && !placed; ++attempt) {
      const double shrink = 1.0 - attempt / 400.0;  // pull the target toward the centre if it will not fit
      const double fill = o.fill_far + (o.fill_near - o.fill_far) * (k % 2 == 0 ? 0.6 + 0.4 * unit(rng) : 0.4 * unit(rng));
      const double distance = std::max(fx * board_mm / (fill * w), fx * board_h_mm / (fill * h));
      const double tilt = o.max_tilt_deg * kRadPerDeg * std::sqrt(unit(rng));
      const double azimuth = 2 * M_PI * unit(rng);
      const Eigen::Vector3d dir(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
      scene.screen_from_cam.translation = distance * dir;
      Eigen::Matrix3d r = ScreenFromCamLookAt(scene.screen_from_cam.translation, Eigen::Vector3d::Zero(),
                                              Eigen::Vector3d::UnitY())
                              .RotationMatrix();
      r = r * Eigen::AngleAxisd(o.max_roll_deg * kRadPerDeg * uni(rng), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      // Turn the camera so that the board centre lands on the target pixel: the ray through the target, v_t,
      // must point at the board, so screen_from_cam' = screen_from_cam * Q with Q v_t = z.
      const Eigen::Vector2d target(0.5 * (w - 1) + shrink * tx + 0.05 * w * uni(rng),
                                   0.5 * (h - 1) + shrink * ty + 0.05 * h * uni(rng));
      const Eigen::Vector3d vt = UnprojectPixels(o.camera, {target})[0].normalized();
      const Eigen::Matrix3d q = Eigen::Quaterniond::FromTwoVectors(vt, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      scene.screen_from_cam = Pose(Eigen::Matrix3d(r * q), scene.screen_from_cam.translation);
      const nlohmann::json t = TruthJson(scene, outline);
      placed = true;
      for (const auto& f : t["features"]) placed = placed && f["visible"].get<bool>();
      if (placed) {
        // Also demand the outline well inside (a margin of 2 px) so that blur does not clip it.
        for (const auto& f : t["features"]) {
          const double x = f["image_px"][0].get<double>(), y = f["image_px"][1].get<double>();
          placed = placed && x > 2 && y > 2 && x < w - 3 && y < h - 3;
        }
      }
      if (placed) {
        SyntheticBoardView v;
        v.screen_from_cam = scene.screen_from_cam;
        v.tilt_deg = tilt / kRadPerDeg;
        const nlohmann::json tc = TruthJson(scene, corners);
        for (const auto& f : tc["features"]) v.corners_px.emplace_back(f["image_px"][0].get<double>(), f["image_px"][1].get<double>());
        scene.sensor.seed = o.seed * 1000 + static_cast<uint64_t>(k);
        const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display);
        PhotoToMat(photo).convertTo(v.photo, CV_8U, photo.bits == 16 ? 255.0 / 65535.0 : 1.0);
        set.views.push_back(std::move(v));
      }
    }
    if (!placed) {
      throw Error("MakeSyntheticBoardSet", fmt::format("view {} could not be placed inside the image", k),
                  "lower fill_near or max_tilt_deg");
    }
  }
  return set;
}

CameraModel StrongOpencv8Lens() {
  CameraModel m;
  m.lensmodel = "LENSMODEL_OPENCV8";
  m.width = 640;
  m.height = 480;
  m.intrinsics = {520, 521, 322.5, 236.5, 0.3, -0.05, 0.0008, -0.0006, 0.02, 0.8, 0.05, 0.01};
  return m;
}

CameraModel WideLens() {
  CameraModel m;
  m.lensmodel = "LENSMODEL_OPENCV8";
  m.width = 640;
  m.height = 480;
  m.intrinsics = {322, 322, 318.5, 241.5, 0.05, 0.0, 0.0005, 0.0004, 0.0, 0.2, 0.0, 0.0};
  return m;
}

}  // namespace curvecheck
