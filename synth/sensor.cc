#include "synth/sensor.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "synth/parallel_rows.h"

namespace curvecheck::synth_internal {
namespace {

// SplitMix64's output function: a bijective 64-bit mix.
inline uint64_t Mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// SplitMix64 (Steele, Lea, Flood 2014): a small, fast generator, one stream per row seeded from (seed, row).
struct SplitMix64 {
  uint64_t state;
  uint64_t Next() { return Mix64(state += 0x9E3779B97F4A7C15ull); }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }  // [0, 1)
  // Standard normal by Marsaglia's polar method (two per accepted pair; the second is kept).
  double Normal() {
    if (has_spare) {
      has_spare = false;
      return spare;
    }
    double a, b, r2;
    do {
      a = 2 * Uniform() - 1;
      b = 2 * Uniform() - 1;
      r2 = a * a + b * b;
    } while (r2 >= 1 || r2 == 0);
    const double f = std::sqrt(-2 * std::log(r2) / r2);
    spare = b * f;
    has_spare = true;
    return a * f;
  }
  // Poisson by Knuth's product of uniforms (for small means only: about mean + 1 uniforms).
  int Poisson(double mean) {
    const double limit = std::exp(-mean);
    int n = 0;
    for (double p = Uniform(); p > limit; p *= Uniform()) ++n;
    return n;
  }
  double spare = 0;
  bool has_spare = false;
};

}  // namespace

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

std::vector<uint16_t> ExposeSensor(const Optics& optics, const Sensor& sensor, const cv::Mat& radiance) {
  const int width = radiance.cols, height = radiance.rows;
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1), r2_corner = cx * cx + cy * cy;
  const double max_code = sensor.bits == 16 ? 65535.0 : 255.0;
  const double full_well = sensor.full_well_e, read2 = sensor.read_noise_e * sensor.read_noise_e;
  std::vector<uint16_t> pixels(static_cast<size_t>(width) * height);
  ParallelRows(height, [&](int y) {
    // One stream per row, seeded from (seed, row), so the noise does not depend on the thread count.
    // The start is hashed: consecutive multiples of the increment would make each row the previous row's
    // stream shifted by one number.
    SplitMix64 rng{Mix64(sensor.seed ^ Mix64(static_cast<uint64_t>(y) + 0x632BE59BD9B4E019ull))};
    const float* row = radiance.ptr<float>(y);
    const double gain_y = optics.exposure, dy2 = (y - cy) * (y - cy);
    uint16_t* out = &pixels[static_cast<size_t>(y) * width];
    for (int x = 0; x < width; ++x) {
      const double r2 = ((x - cx) * (x - cx) + dy2) / r2_corner;
      double v = row[x] * gain_y * (1 - optics.vignetting * r2);
      if (sensor.noise) {
        // Poisson-Gaussian: shot noise of the collected electrons plus Gaussian read noise. Above 20 e the shot
        // noise is Gaussian, and the sum of the two Gaussians is one Gaussian of variance e + read^2; below,
        // Poisson plus read noise.
        const double electrons = std::max(0.0, v * full_well);
        const double e = electrons > 20 ? electrons + std::sqrt(electrons + read2) * rng.Normal()
                                        : rng.Poisson(electrons) + sensor.read_noise_e * rng.Normal();
        v = e / full_well;
      }
      v = std::clamp(v, 0.0, 1.0);
      if (sensor.gamma != 1) v = std::pow(v, 1 / sensor.gamma);
      out[x] = static_cast<uint16_t>(v * max_code + 0.5);
    }
  });
  return pixels;
}

}  // namespace curvecheck::synth_internal
