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
// of each pixel, optionally as three vertical RGB stripes (a monochrome sensor weights them by Rec. 709 luma),
// display gamma, black level, a bezel and a dim room. Then supersampling, Gaussian or disc blur, vignetting,
// exposure, Poisson-Gaussian noise (seeded), sensor gamma and 8- or 16-bit quantization.
//
// This header is the entry point; it includes the public pieces:
//   synth/scene.h        SyntheticScene (display, optics, sensor), the scene reader LoadScene / SceneFromConfig
//   synth/true_monitor.h TrueMonitor (radius, placement, lean, bumps), TrueSurfacePointInScreen
//   synth/ray_grid.h     RayGrid, SharedRayGrid (the lens's rays, precomputed)
//   synth/truth_json.h   TruthJson (truth.json)
// The stages of RenderSyntheticPhoto are internal (namespace synth_internal): true_surface.h (ray against the
// true surface), tracer.h (display sampling, supersampled), sensor.h (blur, vignetting, exposure, noise,
// quantization), parallel_rows.h.
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
  std::vector<uint16_t> pixels;  // row-major code values (0..255 or 0..65535)
  PhotoTiming timing;
};

// Renders the photo of `display` (the display image: gray or colour, the monitor's resolution) as the scene's
// camera sees it. Runs on all cores; the ray table comes from SharedRayGrid. Throws Error if the display image
// does not match the monitor.
SyntheticPhoto RenderSyntheticPhoto(const SyntheticScene& scene, const Image8& display, double ray_grid_px = 16);

// Writes the photo as PNG (8 or 16 bit gray), atomically.
void WriteSyntheticPhoto(const std::filesystem::path& path, const SyntheticPhoto& photo);

// The photo as an OpenCV image, CV_8U or CV_16U by its bit depth (what the detectors take).
cv::Mat PhotoToMat(const SyntheticPhoto& photo);

}  // namespace curvecheck
