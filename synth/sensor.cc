#include "synth/sensor.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/large_buffer.h"
#include "synth/parallel_rows.h"
#include "synth/random.h"

namespace curvecheck::synth_internal {
void BlurRadiance(const Optics& optics, cv::Mat* radiance) {
  if (optics.blur == Blur::kGaussian && optics.blur_px > 0) {
    cv::GaussianBlur(*radiance, *radiance, cv::Size(0, 0), optics.blur_px, optics.blur_px, cv::BORDER_REPLICATE);
  } else if (optics.blur == Blur::kDisc && optics.blur_px > 0) {
    const int r = static_cast<int>(std::ceil(optics.blur_px));
    cv::Mat kernel = cv::Mat::zeros(2 * r + 1, 2 * r + 1, CV_32F);
    cv::circle(kernel, cv::Point(r, r), static_cast<int>(std::lround(optics.blur_px)), cv::Scalar(1), cv::FILLED);
    kernel /= cv::sum(kernel)[0];
    cv::filter2D(*radiance, *radiance, -1, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  }
}

cv::Mat ExposeSensor(const Optics& optics, const Sensor& sensor, const cv::Mat& radiance) {
  const int width = radiance.cols, height = radiance.rows;
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1), r2_corner = cx * cx + cy * cy;
  const double max_code = sensor.bits == 16 ? 65535.0 : 255.0;
  const double full_well = sensor.full_well_e;
  cv::Mat pixels = NewLargeMat(height, width, sensor.bits == 16 ? CV_16U : CV_8U);
  ParallelRows(height, [&](int y) {
    // One stream per row, seeded from (seed, row), so the noise does not depend on the thread count.
    SplitMix64 rng = RowStream(sensor.seed, y);
    const float* row = radiance.ptr<float>(y);
    const double gain_y = optics.exposure, dy2 = (y - cy) * (y - cy);
    uint16_t* out16 = sensor.bits == 16 ? pixels.ptr<uint16_t>(y) : nullptr;
    uint8_t* out8 = pixels.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      const double r2 = ((x - cx) * (x - cx) + dy2) / r2_corner;
      double v = row[x] * gain_y * (1 - optics.vignetting * r2);
      if (sensor.noise) v = NoisyElectrons(v * full_well, sensor.read_noise_e, rng) / full_well;
      v = std::clamp(v, 0.0, 1.0);
      if (sensor.gamma != 1) v = std::pow(v, 1 / sensor.gamma);
      const auto code = static_cast<uint16_t>(v * max_code + 0.5);
      if (out16) {
        out16[x] = code;
      } else {
        out8[x] = static_cast<uint8_t>(code);
      }
    }
  });
  return pixels;
}

}  // namespace curvecheck::synth_internal
