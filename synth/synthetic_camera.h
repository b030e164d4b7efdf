// The synthetic camera (architecture.md, "Synthetic camera"): a ray-traced photo of a true, imperfect monitor
// showing a display image, through any mrcal lens model, with the exact image position of every feature.
//
// Geometry. The nominal monitor and its screen frame are as in core/screen_geometry.h. The true monitor is a
// cylinder of its own curvature (same active width along the surface, same height and pixel grid), leaned (its
// columns tilted, see TrueMonitor::lean_deg), with a smooth deviation field along its normal (positive toward
// the viewer), and placed in the nominal frame by a rigid rotation and translation about the screen centre.
// Rays come from the camera's lens model (mrcal unprojection, precomputed on a grid and interpolated); they
// are intersected analytically with the true cylinder (mapped back through the lean's shear, so the cylinder
// stays upright) and refined by fixed-point steps onto the deviated surface where a bump reaches.
//
// Radiometry. The display is physical pixels: nearest pixel of the display image, emitting over a fill factor
// of each pixel, optionally as three vertical RGB (or BGR) stripes, display gamma, black level, a bezel and a dim
// room. Two chains follow (scene.imaging.preset):
// - clean (the unit tests' mode): a monochrome sensor (the stripes weighted by Rec. 709 luma), supersampling,
//   Gaussian or disc blur, quadratic vignetting, exposure, Poisson-Gaussian noise (seeded), sensor gamma and
//   8- or 16-bit gray;
// - realistic (phone, ilc24, webcam: Imaging in synth/scene.h): R, G, B per ray (one intersection), the panel's
//   luminance against viewing angle, a reflection, veiling glare, the optics' Gaussian with per-pixel defocus
//   from the traced depth, vignetting, exposure, a Bayer RGGB raw in electrons (PRNU, shot and read noise,
//   full-well clipping, ADC bits), demosaicing, tone curve, 8-bit colour and JPEG.
//
// This header is the entry point; it includes the public pieces:
//   synth/scene.h        SyntheticScene (display, optics, sensor), the scene reader LoadScene / SceneFromConfig
//   synth/true_monitor.h TrueMonitor (radius, placement, lean, bumps), TrueSurfacePointInScreen
//   synth/ray_grid.h     RayGrid, SharedRayGrid (the lens's rays, precomputed)
//   synth/truth_json.h   TruthJson (truth.json)
// The stages of RenderSyntheticPhoto are internal (namespace synth_internal): true_surface.h (ray against the
// true surface), tracer.h (display sampling, supersampled), sensor.h (the clean chain's blur, vignetting,
// exposure, noise, quantization), imaging.h (the realistic chain's stages), random.h, parallel_rows.h.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "core/camera_model.h"
#include "core/image_io.h"
#include "core/monitor.h"
#include "synth/ray_grid.h"
#include "synth/scene.h"
#include "synth/true_monitor.h"
#include "synth/truth_json.h"

namespace curvecheck {

// Wall-clock and process CPU time (all threads) per stage, ms. On a machine shared with other work the wall
// times grow while the CPU times do not; cpu / wall shows how many cores the stage actually had.
struct PhotoTiming {
  double rays_ms = 0, rays_cpu_ms = 0;      // ray table from the lens model (0 when it came from the cache)
  double trace_ms = 0, trace_cpu_ms = 0;    // intersection and display sampling, supersampled
  double optics_ms = 0, optics_cpu_ms = 0;  // blur
  double sensor_ms = 0, sensor_cpu_ms = 0;  // vignetting, exposure, noise, gamma, quantization
  int64_t rays = 0;
  int64_t refined_rays = 0;  // rays refined onto the deviation field (inside a bump's support)
  bool rays_cached = false;  // the ray table was built by an earlier photo through the same lens
  int threads = 1;
  double total_ms() const { return rays_ms + trace_ms + optics_ms + sensor_ms; }
  double total_cpu_ms() const { return rays_cpu_ms + trace_cpu_ms + optics_cpu_ms + sensor_cpu_ms; }
};

struct SyntheticPhoto {
  int width = 0, height = 0, bits = 8;
  int channels = 1;  // 1 gray (clean chain), 3 colour B, G, R (realistic chain, 8 bit)
  // The code values as stored: CV_8UC1 or CV_16UC1 (0..255 or 0..65535 by bits) gray, CV_8UC3 B, G, R.
  cv::Mat image;
  std::vector<uint8_t> jpeg;     // the JPEG the pixels were decoded from (realistic chain with a JPEG quality)
  int defocus_levels = 0;        // blur levels blended for the defocus (realistic chain; imaging.h)
  PhotoTiming timing;
};

// Renders the photo of `display` (the display image: gray or colour, the monitor's resolution) as the scene's
// camera sees it. Runs on all cores; the ray table comes from SharedRayGrid. Throws Error if the display image
// does not match the monitor.
SyntheticPhoto RenderSyntheticPhoto(const SyntheticScene& scene, const Image8& display, double ray_grid_px = 16);

// Writes the photo, atomically: as PNG (8 or 16 bit gray, or 8-bit colour; a JPEG-compressed photo's decoded
// pixels, artefacts included), or, for a path ending in .jpg or .jpeg, the photo's JPEG itself (Error if the
// photo has none: imaging.jpeg_quality 0 or the clean chain).
void WriteSyntheticPhoto(const std::filesystem::path& path, const SyntheticPhoto& photo);

// The photo as the detectors take it, CV_8U or CV_16U by its bit depth, one channel, a copy the caller may
// change: a colour photo is turned to gray by ColourPhotoToGray (core/image_decode.h), as detect/ReadPhotoGray
// does with a colour file, so the photo in memory and the photo written and read back are detected alike.
cv::Mat PhotoToMat(const SyntheticPhoto& photo);
// The photo as stored (photo.image, its pixels shared, not copied): CV_8UC3 (B, G, R) for colour, else as
// PhotoToMat.
cv::Mat PhotoToStoredMat(const SyntheticPhoto& photo);

}  // namespace curvecheck
