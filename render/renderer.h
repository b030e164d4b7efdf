// The Vulkan renderer: draws a Pattern as the display must show it for a viewpoint, by one of the correction
// methods, offscreen on any Vulkan device (Mesa lavapipe headless by default on machines without a GPU).
// The API is CPU-side; Vulkan stays inside render/.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/monitor.h"
#include "render/method.h"
#include "pattern/pattern.h"

namespace curvecheck {

struct RenderOptions {
  MethodOptions method;
  // Anti-aliasing mixes black and white in linear light, then encodes the code value for a display of this
  // gamma (code = linear^(1/gamma)); a photo then sees each edge where the pattern puts it. 1 = mix code values.
  double display_gamma = 2.2;
  int surround_code = 128;  // grey code value outside the pattern, 0..255

  void Check(const std::string& where) const;
};

struct GrayImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // row-major, 8-bit code values
};

// Pattern-plane coordinates (a, b) in mm that each display pixel shows, as the method computes them in its own
// pipeline; NaN where the method draws nothing of the plane (the surround).
struct CoordinateImage {
  int width = 0, height = 0;
  std::vector<float> ab;  // row-major pairs (a, b)
};

struct RenderTiming {
  double render_ms = 0;    // GPU work of the frame: submit to completion (device set-up and uploads excluded)
  double upload_ms = 0;    // per-frame uploads (tables, cells, meshes)
  double readback_ms = 0;  // copy to host memory and read
};

class Renderer {
 public:
  // Creates the Vulkan instance and device. Prefers a discrete GPU, else any device; the environment variable
  // CURVECHECK_VULKAN_DEVICE (a substring of the device name) picks one. Throws Error if there is no Vulkan
  // driver or no device can render (with what to install).
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  std::string device_name() const;
  double setup_ms() const;  // instance + device + pipelines created so far

  // Throws Error if the method cannot render this view correctly (it refuses rather than draw a wrong image).
  GrayImage Render(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen, const Pattern& pattern,
                   const RenderOptions& options, RenderTiming* timing = nullptr);
  CoordinateImage RenderCoordinates(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                                    const Pattern& pattern, const RenderOptions& options,
                                    RenderTiming* timing = nullptr);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace curvecheck
