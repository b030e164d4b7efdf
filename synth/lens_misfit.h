// The synthetic camera's true lens is its camera model plus a misfit: the part of a real lens's distortion that
// the calibrated model does not follow (a polynomial or rational model leaves smooth, structured residuals that a
// finer model, such as mrcal's splined one, removes; cameras.md). Part of the synthetic camera's public interface.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/pose.h"
#include "synth/scene.h"

namespace curvecheck {

// delta(q): the true lens images a point at P(X) + delta(P(X)), P the camera model's projection, q in camera px.
// delta is a stationary Gaussian random field per coordinate, drawn as a sum of kModes random cosines
// (Rahimi-Recht random features of the Gaussian covariance exp(-|d|^2 / (2 L^2))), with L = lens_misfit_length x
// the image width, then scaled so that its RMS over the image is exactly lens_misfit_px per coordinate (scaled by
// width / lens_misfit_reference_width: the same lens seen by a smaller imager). Fixed per imaging.lens_seed.
class LensMisfit {
 public:
  static constexpr int kModes = 64;
  LensMisfit(const Imaging& imaging, int width, int height);
  bool active() const { return rms_px_ > 0; }
  double rms_px() const { return rms_px_; }
  Eigen::Vector2d At(const Eigen::Vector2d& q) const;
  // The model pixel q whose true image is p: q + delta(q) = p (two fixed-point steps; |grad delta| is about
  // rms / L, below 1e-3, so the error is below 1e-9 px).
  Eigen::Vector2d ModelPixelOf(const Eigen::Vector2d& p) const;
  // The true image of a model projection q: q + delta(q).
  Eigen::Vector2d TrueImageOf(const Eigen::Vector2d& q) const { return q + At(q); }
  // Identifies the field (for caches of rays): empty when inactive.
  std::string Key() const;

 private:
  double rms_px_ = 0, length_ = 0, width_ = 0;
  uint64_t seed_ = 0;
  struct Mode {
    Eigen::Vector2d omega;  // per px
    double phase;
  };
  std::vector<Mode> modes_[2];
  double amplitude_[2] = {0, 0};
  double Raw(int c, const Eigen::Vector2d& q) const;
};

// The true image of a display position on a synthetic photo: the true surface point where the display shows
// it (TrueSurfacePointInScreen), in the camera frame, through the camera model and the true lens's misfit.
// truth.json's image_px and the benches that measure a detector against the truth use this one copy. Holds
// the scene by reference: it must outlive this, and each call follows the scene's current camera pose (a
// bench that moves the camera from photo to photo keeps one TrueImages). The misfit field depends on the
// imager and the lens seed only.
class TrueImages {
 public:
  explicit TrueImages(const SyntheticScene& scene);
  const LensMisfit& misfit() const { return misfit_; }
  // The true surface point where the display shows display_px, in the camera frame (mm).
  Eigen::Vector3d CameraPoint(const Eigen::Vector2d& display_px) const;
  // The true lens's image of a camera-frame point (in front of the camera): P(X) + delta(P(X)).
  Eigen::Vector2d ImageOf(const Eigen::Vector3d& camera_point) const;
  // Both; nullopt when the point is behind the camera.
  std::optional<Eigen::Vector2d> Of(const Eigen::Vector2d& display_px) const;

 private:
  const SyntheticScene& scene_;
  LensMisfit misfit_;
};

}  // namespace curvecheck
