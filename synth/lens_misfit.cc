#include "synth/lens_misfit.h"

#include <fmt/format.h>

#include <cmath>

#include "core/camera_model.h"
#include "core/screen_geometry.h"
#include "synth/random.h"
#include "synth/true_monitor.h"

namespace curvecheck {

LensMisfit::LensMisfit(const Imaging& imaging, int width, int height) {
  if (!(imaging.lens_misfit_px > 0) || width <= 0 || height <= 0) return;
  const int reference = imaging.lens_misfit_reference_width > 0 ? imaging.lens_misfit_reference_width : width;
  rms_px_ = imaging.lens_misfit_px * width / reference;
  width_ = width;
  length_ = imaging.lens_misfit_length;
  seed_ = imaging.lens_seed;
  const double l_px = length_ * width;
  synth_internal::SplitMix64 rng{synth_internal::Mix64(seed_ ^ 0x6C656E736D697366ull)};
  for (int c = 0; c < 2; ++c) {
    for (int m = 0; m < kModes; ++m) {
      // Spectral density of the Gaussian covariance: omega ~ N(0, I / L^2).
      const double ox = rng.Normal() / l_px, oy = rng.Normal() / l_px;
      modes_[c].push_back({Eigen::Vector2d(ox, oy), 2 * M_PI * rng.Uniform()});
    }
  }
  // Scale each coordinate to RMS rms_px_ over the image (a 64 x 64 grid of cell centres).
  constexpr int kGrid = 64;
  for (int c = 0; c < 2; ++c) {
    double ss = 0;
    for (int j = 0; j < kGrid; ++j) {
      for (int i = 0; i < kGrid; ++i) {
        const double v = Raw(c, {(i + 0.5) * width / kGrid - 0.5, (j + 0.5) * height / kGrid - 0.5});
        ss += v * v;
      }
    }
    const double rms = std::sqrt(ss / (kGrid * kGrid));
    amplitude_[c] = rms > 0 ? rms_px_ / rms : 0;
  }
}

double LensMisfit::Raw(int c, const Eigen::Vector2d& q) const {
  double v = 0;
  for (const Mode& m : modes_[c]) v += std::cos(m.omega.dot(q) + m.phase);
  return v;
}

Eigen::Vector2d LensMisfit::At(const Eigen::Vector2d& q) const {
  if (!active()) return Eigen::Vector2d::Zero();
  return {amplitude_[0] * Raw(0, q), amplitude_[1] * Raw(1, q)};
}

Eigen::Vector2d LensMisfit::ModelPixelOf(const Eigen::Vector2d& p) const {
  if (!active()) return p;
  Eigen::Vector2d q = p - At(p);
  q = p - At(q);
  return p - At(q);
}

std::string LensMisfit::Key() const {
  if (!active()) return "";
  return fmt::format("misfit {:a} {:a} {:a} {}", rms_px_, length_, width_, seed_);
}

TrueImages::TrueImages(const SyntheticScene& scene)
    : scene_(scene), misfit_(scene.imaging, scene.camera.width, scene.camera.height) {}

Eigen::Vector3d TrueImages::CameraPoint(const Eigen::Vector2d& display_px) const {
  return scene_.screen_from_cam.Inverse() *
         TrueSurfacePointInScreen(scene_, UvFromDisplayPx(scene_.monitor, display_px));
}

Eigen::Vector2d TrueImages::ImageOf(const Eigen::Vector3d& camera_point) const {
  return misfit_.TrueImageOf(ProjectPoint(scene_.camera, camera_point));
}

std::optional<Eigen::Vector2d> TrueImages::Of(const Eigen::Vector2d& display_px) const {
  const Eigen::Vector3d x = CameraPoint(display_px);
  if (!(x.z() > 0)) return std::nullopt;
  return ImageOf(x);
}

}  // namespace curvecheck
