// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// The trace stage of RenderSyntheticPhoto: supersampled rays from the lens against the true surface, and the
// display's light where they land (DisplayLight: physical pixels with fill factor and RGB stripes), the bezel's
// or the room's where they do not.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "core/image_io.h"
#include "synth/ray_grid.h"
#include "synth/scene.h"

namespace curvecheck::synth_internal {

// The display as physical pixels, in display pixel coordinates (fx, fy) = ((u + 1) Nx/2, (v + 1) Ny/2) (pixel i
// spans [i, i + 1)): each pixel of the display image emits over the fill factor of its area, optionally as three
// vertical stripes R, G, B left to right (a monochrome sensor weights them by Rec. 709 luma, scaled so that white
// stays 1); black light between emitters. Light is linear, relative to a full white pixel.
class DisplayLight {
 public:
  // Keeps a reference to `image` (gray, or colour as BGR(A)), which must outlive this.
  DisplayLight(const DisplayModel& model, const Image8& image);

  // The light at the point (fx, fy), which must be on the display.
  float ShadePoint(double fx, double fy) const;

  // The light at (fx, fy), on the display, averaged over the box of wx x wy display px centred there: the
  // footprint of one sample. A camera pixel integrates the light over its area; the emitters (fill factor, RGB
  // stripes: a third of a pixel each) are far finer than a sample at ordinary distances (0.78 camera px per
  // display px for the default scene), so point samples alias them into a random texture that no real photo
  // shows. The box average is exact for the separable emitter layout (stripes across, fill factor down), and
  // equals the point sample as the box shrinks.
  //
  // When the optics blur the display's pixel structure away (psf_x, psf_y: the PSF's sigma in display px along
  // each axis, both above kStructureBlurredPx), the emitters are shaded by their mean over a pixel instead: a
  // Gaussian of sigma s passes the pixel grid's fundamental (1 cycle per display px) at exp(-2 pi^2 s^2), under
  // 1e-3 for s > 0.6 display px, so no real photo shows the structure there. Resolving it anyway would alias it,
  // since the simulated blur acts after sampling and a real lens acts before.
  float ShadeArea(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const;

  static constexpr double kStructureBlurredPx = 0.6;

 private:
  // Linear light of the (whole, unstriped) pixel at byte offset `at`: the mean of its colour channels.
  float GrayLight(size_t at) const;

  const Image8& image_;
  float black_;
  double half_fill_;
  bool stripes_;
  int channels_;
  std::array<std::array<float, 256>, 3> stripe_light_;  // luma-weighted linear light of stripe R, G, B per code
  std::array<float, 256> gray_light_;                   // linear light per code (no stripes)
  // Mean light of each display pixel over its whole area (emitters at their light, black between them):
  // what ShadeArea uses where the optics blur the pixel structure away. Row-major, display size.
  std::vector<float> pixel_mean_light_;
};

// The radiance each camera pixel of `scene` collects from `display` (CV_32F, the camera's size, relative to a full
// white display pixel): the mean of supersample x supersample samples, each the display's light over its
// footprint, or the bezel's or room's radiance; before blur, vignetting and exposure. Rays come from `rays` (the
// scene camera's table); `refined_rays` is set to the number of samples refined onto the deviation field.
// Runs on all cores. The display image must have the monitor's size.
cv::Mat TraceRadiance(const SyntheticScene& scene, const Image8& display, const RayGrid& rays,
                      int64_t* refined_rays);

}  // namespace curvecheck::synth_internal
