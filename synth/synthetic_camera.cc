#include "synth/synthetic_camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_decode.h"
#include "core/stopwatch.h"
#include "synth/imaging.h"
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

namespace {

// The realistic colour chain (synthetic_camera.h; the stages in imaging.h) after the ray table.
void RenderColour(const SyntheticScene& s, const Image8& display, const RayGrid& rays, StageTimer* timer,
                  SyntheticPhoto* photo) {
  using namespace synth_internal;
  const Imaging& g = s.imaging;
  PhotoTiming& timing = photo->timing;
  ColourTrace trace = TraceColour(s, display, rays);
  timing.refined_rays = trace.refined_rays;
  timer->Lap(&timing.trace_ms, &timing.trace_cpu_ms);

  // Optics: glare, then the Gaussian of the optics combined with the defocus at each pixel's depth. Auto focus:
  // the depth at the image centre (the screen there), else the distance to the screen centre.
  AddVeilingGlare(g.glare, &trace.radiance);
  double focus_mm = g.focus_mm;
  if (focus_mm <= 0) {
    const float centre = trace.depth_mm.at<float>(trace.depth_mm.rows / 2, trace.depth_mm.cols / 2);
    focus_mm = std::isfinite(centre) ? centre : s.screen_from_cam.translation.norm();
  }
  const double focal_mm = FocalLengthMm(s.camera, g);
  // The PSF's sigma per pixel, written over the depth (which nothing reads after this): one full-size buffer less.
  cv::Mat sigma = trace.depth_mm;
  ParallelRows(sigma.rows, [&](int y) {
    float* d = sigma.ptr<float>(y);
    for (int x = 0; x < sigma.cols; ++x) {
      const double defocus = DefocusSigmaPx(d[x], focus_mm, focal_mm, g.f_number, g.pixel_pitch_um);
      d[x] = static_cast<float>(std::sqrt(g.blur_px * g.blur_px + defocus * defocus));
    }
  });
  photo->defocus_levels = BlurBySigmaMap(sigma, &trace.radiance);
  timer->Lap(&timing.optics_ms, &timing.optics_cpu_ms);

  // The raw in the sigma map's memory, the demosaiced image in the radiance's, each done with by then: fresh
  // pages cost ~1 CPU-s per 400 MB on the shared machine (issue 18), reused ones nothing.
  const cv::Mat raw = ExposeRaw(g, s.sensor, trace.radiance, sigma);
  cv::Mat bgr8 = ToneMap8(DemosaicRaw(raw, g, trace.radiance), g.raw_bits, g.tone);
  trace.radiance.release();
  trace.depth_mm.release();
  if (g.jpeg_quality > 0) {
    photo->jpeg = EncodeJpeg(bgr8, g.jpeg_quality);
    bgr8 = DecodeJpeg(photo->jpeg, bgr8);  // into the tone-mapped image's pixels, which the JPEG replaces
  }
  photo->bits = 8;
  photo->channels = 3;
  photo->image = bgr8;
  timer->Lap(&timing.sensor_ms, &timing.sensor_cpu_ms);
}

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
  const LensMisfit misfit(s.imaging, s.camera.width, s.camera.height);
  const std::shared_ptr<const RayGrid> rays =
      SharedRayGrid(s.camera, ray_grid_px, &timing.rays_cached, misfit.active() ? &misfit : nullptr);
  timer.Lap(&timing.rays_ms, &timing.rays_cpu_ms);
  timing.rays = static_cast<int64_t>(photo.width) * photo.height * s.optics.supersample * s.optics.supersample;
  if (s.imaging.preset != ImagingPreset::kClean) {
    RenderColour(s, display, *rays, &timer, &photo);
    return photo;
  }

  cv::Mat radiance = synth_internal::TraceRadiance(s, display, *rays, &timing.refined_rays);
  timer.Lap(&timing.trace_ms, &timing.trace_cpu_ms);

  synth_internal::BlurRadiance(s.optics, &radiance);
  timer.Lap(&timing.optics_ms, &timing.optics_cpu_ms);

  photo.image = synth_internal::ExposeSensor(s.optics, s.sensor, radiance);
  timer.Lap(&timing.sensor_ms, &timing.sensor_cpu_ms);
  return photo;
}

cv::Mat PhotoToStoredMat(const SyntheticPhoto& photo) { return photo.image; }

cv::Mat PhotoToMat(const SyntheticPhoto& photo) {
  if (photo.channels != 3) return photo.image.clone();
  return ColourPhotoToGray(photo.image);
}

void WriteSyntheticPhoto(const std::filesystem::path& path, const SyntheticPhoto& photo) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".jpg" || ext == ".jpeg") {
    if (photo.jpeg.empty()) {
      throw Error(path.string(), "the photo has no JPEG (clean chain, or imaging.jpeg_quality 0)",
                  "write a .png, or give a realistic imaging preset with a JPEG quality");
    }
    WriteFileAtomic(path, std::string(photo.jpeg.begin(), photo.jpeg.end()));
    return;
  }
  const cv::Mat& image = photo.image;
  CV_Assert(image.isContinuous());
  if (photo.bits == 8) {
    WritePng8(path, image.cols, image.rows, image.channels(), image.ptr<uint8_t>(0));
  } else {
    WritePng16(path, image.cols, image.rows, image.ptr<uint16_t>(0));
  }
}

}  // namespace curvecheck
