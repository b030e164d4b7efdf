// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// The trace stage of RenderSyntheticPhoto: supersampled rays from the lens against the true surface, and the
// display's light where they land (DisplayLight: physical pixels with fill factor and RGB stripes), the bezel's
// or the room's where they do not.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <memory>
#include <vector>

#include "core/image_io.h"
#include "synth/ray_grid.h"
#include "synth/scene.h"

namespace curvecheck::synth_internal {

// Light of the N channels a sample carries: N = 1, the monochrome chain's luma-weighted light; N = 3, the
// colour chain's R, G, B (in that order).
template <int N>
using Light = std::array<float, N>;

// The display as physical pixels, in display pixel coordinates (fx, fy) = ((u + 1) Nx/2, (v + 1) Ny/2) (pixel i
// spans [i, i + 1)): each pixel of the display image emits over the fill factor of its area, optionally as three
// vertical stripes (R, G, B left to right, or B, G, R); black light between emitters. Light is linear, relative
// to a full white pixel. A monochrome sensor (N = 1) weights the stripes by Rec. 709 luma, scaled so that white
// stays 1; a colour sensor (N = 3) sees each stripe in its own channel (ideal, white-balanced colour filters: a
// stripe of a third of the pixel emits 3x its light there, so a white pixel is 1 in each channel).
class DisplayLight {
 public:
  // Keeps a reference to `image` (gray, or colour as BGR(A)), which must outlive this. `channels`: the N of the
  // ShadeArea calls that will come (1 or 3; the per-pixel means are precomputed for it).
  DisplayLight(const DisplayModel& model, const Image8& image, int channels = 1);

  // The light at the point (fx, fy), which must be on the display.
  template <int N>
  Light<N> ShadePointN(double fx, double fy) const;
  float ShadePoint(double fx, double fy) const { return ShadePointN<1>(fx, fy)[0]; }

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
  template <int N>
  Light<N> ShadeAreaN(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const;
  float ShadeArea(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const {
    return ShadeAreaN<1>(fx, fy, wx, wy, psf_x, psf_y)[0];
  }

  static constexpr double kStructureBlurredPx = 0.6;

 private:
  // The code value of colour c (0 R, 1 G, 2 B) of the pixel at byte offset `at` (gray images: the one channel).
  uint8_t Code(size_t at, int c) const { return image_.pixels[at + static_cast<size_t>(channels_ >= 3 ? 2 - c : 0)]; }
  // Linear light of the (whole, unstriped) pixel at byte offset `at`: the mean of its colour channels.
  float GrayLight(size_t at) const;
  // Adds w x the light of the stripe of colour c (or of the whole unstriped pixel, c < 0) of the pixel at `at`.
  template <int N>
  void Add(std::array<double, N>& acc, double w, size_t at, int c) const;

  const Image8& image_;
  float black_;
  double half_fill_;
  bool stripes_;
  int channels_;
  std::array<int, 3> stripe_colour_;                    // colour (0 R, 1 G, 2 B) of the stripe at position 0, 1, 2
  std::array<std::array<float, 256>, 3> stripe_light_;  // luma-weighted linear light of an R, G, B stripe per code
  std::array<float, 256> stripe3_light_;                // 3 x linear light per code (a stripe in its own channel)
  std::array<float, 256> gray_light_;                   // linear light per code (no stripes)
  // Mean light of each display pixel over its whole area (emitters at their light, black between them): what
  // ShadeArea uses where the optics blur the pixel structure away. For N = 1 per pixel (row-major, display size;
  // the stripes' luma mixes the three codes), filled in parallel by display rows without a zero fill first; for
  // N = 3 a function of each channel's code, channel_mean_light_ (a per-pixel table was 88 MB of fresh memory at
  // 5120 x 1440, whose first touch cost more than the lookups it saved, issue 18).
  std::array<float, 256> channel_mean_light_;
  std::unique_ptr<float[]> pixel_mean_light_;
};

// The radiance each camera pixel of `scene` collects from `display` (CV_32F, the camera's size, relative to a full
// white display pixel): the mean of supersample x supersample samples, each the display's light over its
// footprint, or the bezel's or room's radiance; before blur, vignetting and exposure. Rays come from `rays` (the
// scene camera's table); `refined_rays` is set to the number of samples refined onto the deviation field.
// Runs on all cores. The display image must have the monitor's size.
cv::Mat TraceRadiance(const SyntheticScene& scene, const Image8& display, const RayGrid& rays,
                      int64_t* refined_rays);

// The colour chain's trace (scene.imaging): as TraceRadiance, one intersection per ray and three channels, with
// the display's light times the panel's relative luminance at the ray's angle from the surface normal
// (PanelLuminance) plus the reflection blob (Imaging::reflection, on the display). `radiance`: CV_32FC3 in
// OpenCV's order B, G, R; `depth_mm`: CV_32F, the depth along the optical axis of each pixel's first sample that
// hits the screen or bezel (NaN where all see the room); the panel's luminance is taken there too.
struct ColourTrace {
  cv::Mat radiance, depth_mm;
  int64_t refined_rays = 0;
};
ColourTrace TraceColour(const SyntheticScene& scene, const Image8& display, const RayGrid& rays);

// The panel's luminance relative to its normal's at `angle_deg` from the surface normal: linear in angle between
// the table's points (0, 30, 45, 60 deg; 0 at 90 deg). IPS 1 / 0.85 / 0.70 / 0.50, VA 1 / 0.75 / 0.50 / 0.30,
// OLED 1 / 0.90 / 0.80 / 0.65 (cameras.md, estimates); none: 1.
double PanelLuminance(PanelAngular panel, double angle_deg);

}  // namespace curvecheck::synth_internal
