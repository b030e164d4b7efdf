#include "synth/tracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "synth/parallel_rows.h"
#include "synth/true_surface.h"

namespace curvecheck::synth_internal {
namespace {

// Where a ray lands: the true surface (SurfaceIntersector), then the display, the bezel around it or the room.
// `display` is the display image (the monitor's size).
class Landing {
 public:
  Landing(const SyntheticScene& s, const Image8& display)
      : bezel_u_(1 + 2 * s.display.bezel_mm / s.monitor.width_mm),
        bezel_v_(1 + 2 * s.display.bezel_mm / s.monitor.height_mm),
        surface_(s, bezel_v_),
        px_per_u_(0.5 * s.monitor.width_px),
        py_per_v_(0.5 * s.monitor.height_px),
        width_px_(display.width),
        height_px_(display.height),
        room_(static_cast<float>(s.display.room)),
        bezel_(static_cast<float>(s.display.bezel)) {}

  // Camera-frame ray directions to the frame Hit takes them in (SurfaceIntersector::upright_from_cam).
  const Eigen::Matrix3d& upright_from_cam() const { return surface_.upright_from_cam(); }

  // Where the ray d (upright frame) meets the screen: true with the display pixel coordinates (fx, fy) when it
  // lands on the display; false with the radiance of what it sees otherwise (bezel, room). `refined` counts rays
  // refined onto the deviation field.
  bool Hit(const Eigen::Vector3d& d, int64_t* refined, double* fx, double* fy, float* other) const {
    double u, v;
    if (!surface_.Intersect(d, refined, &u, &v)) {
      *other = room_;
      return false;
    }
    *fx = (u + 1) * px_per_u_;
    *fy = (v + 1) * py_per_v_;
    if (!(*fx >= 0 && *fy >= 0 && *fx < width_px_ && *fy < height_px_)) {
      *other = (std::abs(u) <= bezel_u_ && std::abs(v) <= bezel_v_) ? bezel_ : room_;
      return false;
    }
    return true;
  }

 private:
  double bezel_u_, bezel_v_;  // half-extent of bezel + display in u, v
  SurfaceIntersector surface_;
  double px_per_u_, py_per_v_;  // display px + 0.5 = (u + 1) px_per_u
  int width_px_, height_px_;
  float room_, bezel_;
};

}  // namespace

DisplayLight::DisplayLight(const DisplayModel& model, const Image8& image)
    : image_(image),
      black_(static_cast<float>(model.black)),
      half_fill_(0.5 * model.fill_factor),
      stripes_(model.rgb_stripes),
      channels_(image.channels) {
  static constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
  for (int c = 0; c < 256; ++c) {
    const double light = model.black + (1 - model.black) * std::pow(c / 255.0, model.gamma);
    for (int st = 0; st < 3; ++st) stripe_light_[st][c] = static_cast<float>(3 * kLuma[st] * light);
    gray_light_[c] = static_cast<float>(light);
  }
  const double fill_area = model.fill_factor * model.fill_factor;
  pixel_mean_light_.resize(static_cast<size_t>(image.width) * image.height);
  for (size_t p = 0; p < pixel_mean_light_.size(); ++p) {
    const size_t at = p * channels_;
    double emitted = 0;
    if (!stripes_) {
      emitted = GrayLight(at);
    } else {
      for (int stripe = 0; stripe < 3; ++stripe) {
        const int channel = channels_ >= 3 ? 2 - stripe : 0;
        emitted += stripe_light_[stripe][image_.pixels[at + static_cast<size_t>(channel)]] / 3.0;
      }
    }
    pixel_mean_light_[p] = static_cast<float>(fill_area * emitted + (1 - fill_area) * model.black);
  }
}

float DisplayLight::ShadeArea(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const {
  const double x0 = fx - 0.5 * wx, x1 = fx + 0.5 * wx, y0 = fy - 0.5 * wy, y1 = fy + 0.5 * wy;
  // Tiny boxes, boxes that reach past the display's edge and huge ones (far away: many display pixels per
  // sample, where the image content aliases anyway) are point-sampled.
  if (!(wx > 1e-3 && wy > 1e-3) || wx > 16 || wy > 16 || x0 < 0 || y0 < 0 || x1 >= image_.width ||
      y1 >= image_.height) {
    return ShadePoint(fx, fy);
  }
  const auto overlap = [](double a0, double a1, double b0, double b1) {
    return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
  };
  const int i0 = static_cast<int>(x0), i1 = static_cast<int>(x1);
  const int j0 = static_cast<int>(y0), j1 = static_cast<int>(y1);
  double light = 0, lit_area = 0;
  if (psf_x > kStructureBlurredPx && psf_y > kStructureBlurredPx) {
    // Each pixel's mean light (pixel_mean_light_), weighted by its share of the box.
    for (int j = j0; j <= j1; ++j) {
      const double oy = overlap(y0, y1, j, j + 1);
      const float* row = pixel_mean_light_.data() + static_cast<size_t>(j) * image_.width;
      for (int i = i0; i <= i1; ++i) light += overlap(x0, x1, i, i + 1) * oy * row[i];
    }
    return static_cast<float>(light / ((x1 - x0) * (y1 - y0)));
  }
  for (int j = j0; j <= j1; ++j) {
    const double oy = overlap(y0, y1, j + 0.5 - half_fill_, j + 0.5 + half_fill_);
    if (oy <= 0) continue;
    const size_t row = static_cast<size_t>(j) * image_.width;
    for (int i = i0; i <= i1; ++i) {
      const size_t at = (row + static_cast<size_t>(i)) * channels_;
      if (!stripes_) {
        const double ox = overlap(x0, x1, i + 0.5 - half_fill_, i + 0.5 + half_fill_);
        if (ox <= 0) continue;
        light += ox * oy * GrayLight(at);
        lit_area += ox * oy;
        continue;
      }
      for (int stripe = 0; stripe < 3; ++stripe) {
        const double ox = overlap(x0, x1, i + (stripe + 0.5 - half_fill_) / 3, i + (stripe + 0.5 + half_fill_) / 3);
        if (ox <= 0) continue;
        const int channel = channels_ >= 3 ? 2 - stripe : 0;
        light += ox * oy * stripe_light_[stripe][image_.pixels[at + static_cast<size_t>(channel)]];
        lit_area += ox * oy;
      }
    }
  }
  const double area = (x1 - x0) * (y1 - y0);
  return static_cast<float>((light + black_ * (area - lit_area)) / area);
}

float DisplayLight::ShadePoint(double fx_full, double fy_full) const {
  // Truncation is the floor for the non-negative values that reach it (std::floor is a call without SSE4.1).
  const int i = static_cast<int>(fx_full), j = static_cast<int>(fy_full);
  const double fx = fx_full - i, fy = fy_full - j;
  if (std::abs(fy - 0.5) > half_fill_) return black_;
  const size_t at = (static_cast<size_t>(j) * image_.width + static_cast<size_t>(i)) * channels_;
  if (!stripes_) {
    if (std::abs(fx - 0.5) > half_fill_) return black_;
    return GrayLight(at);
  }
  // Stripes R, G, B left to right; a monochrome sensor weights them by luma, scaled so white stays 1.
  const int stripe = std::min(2, static_cast<int>(fx * 3));
  const double local = fx * 3 - stripe;
  if (std::abs(local - 0.5) > half_fill_) return black_;
  // Image8 colour is BGR(A): R is channel 2.
  const int channel = channels_ >= 3 ? 2 - stripe : 0;
  return stripe_light_[stripe][image_.pixels[at + static_cast<size_t>(channel)]];
}

float DisplayLight::GrayLight(size_t at) const {
  if (channels_ == 1) return gray_light_[image_.pixels[at]];
  const int n = std::min(channels_, 3);
  float sum = 0;
  for (int c = 0; c < n; ++c) sum += gray_light_[image_.pixels[at + static_cast<size_t>(c)]];
  return sum / static_cast<float>(n);
}

cv::Mat TraceRadiance(const SyntheticScene& s, const Image8& display, const RayGrid& rays, int64_t* refined_rays) {
  const Landing landing(s, display);
  const DisplayLight light(s.display, display);
  // The optics' blur as a Gaussian sigma, camera px (a disc of radius r: r / 2).
  double psf_sigma_px = 0;
  if (s.optics.blur == Blur::kGaussian) psf_sigma_px = s.optics.blur_px;
  if (s.optics.blur == Blur::kDisc) psf_sigma_px = 0.5 * s.optics.blur_px;
  const int width = s.camera.width, height = s.camera.height;
  const int n = s.optics.supersample;
  const int samples_x = width * n;
  // The dense-table column and fraction of every sample's x, the same for all rows.
  std::vector<int> column(static_cast<size_t>(samples_x));
  std::vector<double> fraction(static_cast<size_t>(samples_x));
  for (int x = 0; x < width; ++x) {
    for (int a = 0; a < n; ++a) {
      const size_t at = static_cast<size_t>(x) * n + static_cast<size_t>(a);
      rays.DenseColumn(x + (a + 0.5) / n - 0.5, &column[at], &fraction[at]);
    }
  }
  cv::Mat radiance(height, width, CV_32F);
  std::atomic<int64_t> refined_total{0};
  ParallelRows(height, [&](int y) {
    thread_local std::vector<Eigen::Vector2d> nodes;
    thread_local std::vector<Eigen::Vector3d> row_dirs;
    // Per sample row of this camera row: display coordinates of every sample (NaN off the display) and the
    // radiance of the samples that miss the display. One extra sample row (a camera pixel below) when n = 1, for
    // the vertical footprint.
    const int sample_rows = std::max(n, 2);
    thread_local std::vector<double> fxs, fys;
    thread_local std::vector<float> others;
    fxs.assign(static_cast<size_t>(sample_rows) * samples_x, 0.0);
    fys.assign(fxs.size(), 0.0);
    others.assign(fxs.size(), 0.0f);
    int64_t refined = 0, unused_refined = 0;
    for (int b = 0; b < sample_rows; ++b) {
      // Directions of this sample row at the dense columns, already in the upright frame (interpolation and the
      // fixed 3 x 3 commute: both are linear).
      rays.RowNodes(y + (b + 0.5) / n - 0.5, &nodes);
      row_dirs.resize(nodes.size());
      for (size_t i = 0; i < nodes.size(); ++i) {
        row_dirs[i] = landing.upright_from_cam() * Eigen::Vector3d(nodes[i].x(), nodes[i].y(), 1.0);
      }
      const size_t base = static_cast<size_t>(b) * samples_x;
      for (int sx = 0; sx < samples_x; ++sx) {
        const size_t i = static_cast<size_t>(column[static_cast<size_t>(sx)]);
        const double f = fraction[static_cast<size_t>(sx)];
        double fx = 0, fy = 0;
        float other = 0;
        if (landing.Hit((1 - f) * row_dirs[i] + f * row_dirs[i + 1], b < n ? &refined : &unused_refined, &fx, &fy,
                        &other)) {
          fxs[base + static_cast<size_t>(sx)] = fx;
          fys[base + static_cast<size_t>(sx)] = fy;
        } else {
          fxs[base + static_cast<size_t>(sx)] = std::numeric_limits<double>::quiet_NaN();
          others[base + static_cast<size_t>(sx)] = other;
        }
      }
    }
    // Footprint of a sample in display px: the bounding box of the parallelogram spanned by the differences to
    // the neighbouring samples across (dx) and down (dy); one-sided at the ends, point samples where a
    // neighbour is off the display.
    float* row = radiance.ptr<float>(y);
    std::fill(row, row + width, 0.0f);
    for (int b = 0; b < n; ++b) {
      const size_t base = static_cast<size_t>(b) * samples_x;
      const size_t below = static_cast<size_t>(b + 1 < sample_rows ? b + 1 : b - 1) * samples_x;
      for (int sx = 0; sx < samples_x; ++sx) {
        const size_t at = base + static_cast<size_t>(sx);
        const double fx = fxs[at];
        float value;
        if (std::isnan(fx)) {
          value = others[at];
        } else {
          const size_t left = sx > 0 ? at - 1 : at, right = sx + 1 < samples_x ? at + 1 : at;
          const double span = static_cast<double>(right - left);
          const double dxx = (fxs[right] - fxs[left]) / span, dxy = (fys[right] - fys[left]) / span;
          const size_t v = below + static_cast<size_t>(sx);
          const double dyx = fxs[v] - fx, dyy = fys[v] - fys[at];
          const double wx = std::abs(dxx) + std::abs(dyx), wy = std::abs(dxy) + std::abs(dyy);
          // The PSF in display px: footprints are per sample (1/n camera px).
          const double psf_x = psf_sigma_px * n * wx, psf_y = psf_sigma_px * n * wy;
          value = std::isnan(wx) || std::isnan(wy) ? light.ShadePoint(fx, fys[at])
                                                   : light.ShadeArea(fx, fys[at], wx, wy, psf_x, psf_y);
        }
        row[sx / n] += value;
      }
    }
    const float scale = 1.0f / static_cast<float>(n * n);
    for (int x = 0; x < width; ++x) row[x] *= scale;
    refined_total += refined;
  });
  *refined_rays = refined_total;
  return radiance;
}

}  // namespace curvecheck::synth_internal
