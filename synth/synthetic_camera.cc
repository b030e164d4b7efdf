#include "synth/synthetic_camera.h"

#include <fmt/format.h>

#include <ctime>

#include "core/error.h"
#include "core/stopwatch.h"
#include "synth/parallel_rows.h"
#include "synth/sensor.h"
#include "synth/tracer.h"

namespace curvecheck {
namespace {

// CPU time of the whole process (all threads), ms.
double ProcessCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

// Wall-clock (Stopwatch) and process CPU time of one stage of the photo.
class StageTimer {
 public:
  // Stores the time since construction or the last Lap, then starts the next stage.
  void Lap(double* wall_ms, double* cpu_ms) {
    *wall_ms = wall_.Ms();
    *cpu_ms = ProcessCpuMs() - cpu_start_ms_;
    wall_.Restart();
    cpu_start_ms_ = ProcessCpuMs();
  }

 private:
  Stopwatch wall_;
  double cpu_start_ms_ = ProcessCpuMs();
};

}  // namespace

SyntheticPhoto RenderSyntheticPhoto(const SyntheticScene& s, const Image8& display, double ray_grid_px) {
  if (display.width != s.monitor.width_px || display.height != s.monitor.height_px) {
    throw Error("display image",
                fmt::format("is {}x{} px but the monitor is {}x{}", display.width, display.height, s.monitor.width_px,
                            s.monitor.height_px),
                "render the pattern for this monitor");
  }
  SyntheticPhoto photo;
  photo.width = s.camera.width;
  photo.height = s.camera.height;
  photo.bits = s.sensor.bits;
  PhotoTiming& timing = photo.timing;
  timing.threads = synth_internal::ThreadCount();
  StageTimer timer;
  const std::shared_ptr<const RayGrid> rays = SharedRayGrid(s.camera, ray_grid_px, &timing.rays_cached);
  timer.Lap(&timing.rays_ms, &timing.rays_cpu_ms);

  cv::Mat radiance = synth_internal::TraceRadiance(s, display, *rays, &timing.refined_rays);
  timing.rays = static_cast<int64_t>(photo.width) * photo.height * s.optics.supersample * s.optics.supersample;
  timer.Lap(&timing.trace_ms, &timing.trace_cpu_ms);

  synth_internal::BlurRadiance(s.optics, &radiance);
  timer.Lap(&timing.optics_ms, &timing.optics_cpu_ms);

  photo.pixels = synth_internal::ExposeSensor(s.optics, s.sensor, radiance);
  timer.Lap(&timing.sensor_ms, &timing.sensor_cpu_ms);
  return photo;
}

cv::Mat PhotoToMat(const SyntheticPhoto& photo) {
  cv::Mat image(photo.height, photo.width, photo.bits == 8 ? CV_8U : CV_16U);
  for (size_t i = 0; i < photo.pixels.size(); ++i) {
    if (photo.bits == 8) {
      image.data[i] = static_cast<uint8_t>(photo.pixels[i]);
    } else {
      image.ptr<uint16_t>(0)[i] = photo.pixels[i];
    }
  }
  return image;
}

void WriteSyntheticPhoto(const std::filesystem::path& path, const SyntheticPhoto& photo) {
  if (photo.bits == 8) {
    std::vector<uint8_t> bytes(photo.pixels.begin(), photo.pixels.end());
    WritePng8(path, photo.width, photo.height, 1, bytes.data());
  } else {
    WritePng16(path, photo.width, photo.height, photo.pixels.data());
  }
}

}  // namespace curvecheck
