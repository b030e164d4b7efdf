#include "synth/tracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/large_buffer.h"
#include "core/math_util.h"

#include "synth/parallel_rows.h"
#include "synth/true_surface.h"

namespace curvecheck::synth_internal {
namespace {

// Where a ray lands: the true surface (SurfaceIntersector), then the display, the bezel around it or the room.
// `display` is the display image (the monitor's size).
class Landing {
 public:
  Landing(const SyntheticScene& s, const Image8& display)
      : bezel_u_(1 + 2 * s.display.bezel_mm / (s.monitor.width_mm * s.truth.pitch_scale)),
        bezel_v_(1 + 2 * s.display.bezel_mm / (s.monitor.height_mm * s.truth.pitch_scale)),
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
  // refined onto the deviation field. `geometry` (optional): the hit's depth and incidence; depth NaN for the room.
  bool Hit(const Eigen::Vector3d& d, int64_t* refined, double* fx, double* fy, float* other,
           SurfaceIntersector::HitGeometry* geometry = nullptr) const {
    double u, v;
    if (!surface_.Intersect(d, refined, &u, &v, geometry)) {
      *other = room_;
      if (geometry) geometry->t = std::numeric_limits<double>::quiet_NaN();
      return false;
    }
    *fx = (u + 1) * px_per_u_;
    *fy = (v + 1) * py_per_v_;
    if (!(*fx >= 0 && *fy >= 0 && *fx < width_px_ && *fy < height_px_)) {
      const bool bezel = std::abs(u) <= bezel_u_ && std::abs(v) <= bezel_v_;
      *other = bezel ? bezel_ : room_;
      if (geometry && !bezel) geometry->t = std::numeric_limits<double>::quiet_NaN();
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

// The colour chain's terms at a display hit: the panel's luminance against the incidence (a table over the
// cosine, 1024 steps: PanelLuminance is linear in angle, and acos per sample would cost a third of the trace) and
// the reflection blob.
class ColourTerms {
 public:
  explicit ColourTerms(const SyntheticScene& s)
      : reflection_(s.imaging.reflection),
        mm_per_u_(0.5 * s.monitor.width_mm * s.truth.pitch_scale),
        mm_per_v_(0.5 * s.monitor.height_mm * s.truth.pitch_scale),
        u_per_px_(2.0 / s.monitor.width_px),
        v_per_px_(2.0 / s.monitor.height_px) {
    for (int i = 0; i <= kSteps; ++i) {
      const double angle_deg = std::acos(static_cast<double>(i) / kSteps) / kRadPerDeg;
      luminance_[static_cast<size_t>(i)] = static_cast<float>(PanelLuminance(s.imaging.panel, angle_deg));
    }
  }
  // The display's relative luminance seen at this incidence (interpolated in the table).
  float Luminance(double cos_incidence) const {
    const double at = std::clamp(cos_incidence, 0.0, 1.0) * kSteps;
    const int i = std::min(kSteps - 1, static_cast<int>(at));
    const float f = static_cast<float>(at - i);
    return (1 - f) * luminance_[static_cast<size_t>(i)] + f * luminance_[static_cast<size_t>(i) + 1];
  }
  // The reflection's radiance at display pixel coordinates (fx, fy).
  float Reflection(double fx, double fy) const {
    if (reflection_.strength <= 0) return 0;
    const double du = (fx * u_per_px_ - 1 - reflection_.u) * mm_per_u_ / reflection_.sigma_mm;
    const double dv = (fy * v_per_px_ - 1 - reflection_.v) * mm_per_v_ / reflection_.sigma_mm;
    const double r2 = du * du + dv * dv;
    return r2 > 36 ? 0.0f : static_cast<float>(reflection_.strength * std::exp(-0.5 * r2));
  }

 private:
  static constexpr int kSteps = 1024;
  Imaging::Reflection reflection_;
  double mm_per_u_, mm_per_v_, u_per_px_, v_per_px_;
  std::array<float, kSteps + 1> luminance_;
};

}  // namespace

DisplayLight::DisplayLight(const DisplayModel& model, const Image8& image, int channels)
    : image_(image),
      black_(static_cast<float>(model.black)),
      half_fill_(0.5 * model.fill_factor),
      stripes_(model.rgb_stripes),
      channels_(image.channels) {
  static constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
  stripe_colour_ = model.stripes_bgr ? std::array<int, 3>{2, 1, 0} : std::array<int, 3>{0, 1, 2};
  for (int c = 0; c < 256; ++c) {
    const double light = model.black + (1 - model.black) * std::pow(c / 255.0, model.gamma);
    for (int colour = 0; colour < 3; ++colour) stripe_light_[colour][c] = static_cast<float>(3 * kLuma[colour] * light);
    stripe3_light_[c] = static_cast<float>(3 * light);
    gray_light_[c] = static_cast<float>(light);
  }
  const double fill_area = model.fill_factor * model.fill_factor;
  // A colour sensor: each channel's mean is its stripe's 3x light over a third of the pixel, or the whole
  // pixel's light, so a function of that channel's code alone (a table per code, not per pixel).
  for (int c = 0; c < 256; ++c) {
    const double mean = fill_area * gray_light_[static_cast<size_t>(c)] + (1 - fill_area) * model.black;
    channel_mean_light_[static_cast<size_t>(c)] = static_cast<float>(mean);
  }
  if (channels == 3) return;
  const size_t width = static_cast<size_t>(image.width);
  // Default-initialised (no zero fill): every element is written below, each row by one thread.
  const size_t values = width * image.height;
  pixel_mean_light_.reset(new float[values]);
  AdviseHugePages(pixel_mean_light_.get(), values * sizeof(float));
  ParallelRows(image.height, [&](int y) {
    for (size_t p = static_cast<size_t>(y) * width; p < (static_cast<size_t>(y) + 1) * width; ++p) {
      const size_t at = p * channels_;
      double emitted = 0;
      if (!stripes_) {
        emitted = GrayLight(at);
      } else {
        for (int colour = 0; colour < 3; ++colour) emitted += stripe_light_[colour][Code(at, colour)] / 3.0;
      }
      pixel_mean_light_[p] = static_cast<float>(fill_area * emitted + (1 - fill_area) * model.black);
    }
  });
}

template <int N>
void DisplayLight::Add(std::array<double, N>& acc, double w, size_t at, int c) const {
  if constexpr (N == 1) {
    acc[0] += w * (c < 0 ? GrayLight(at) : stripe_light_[static_cast<size_t>(c)][Code(at, c)]);
  } else if (c < 0) {
    for (int k = 0; k < 3; ++k) acc[static_cast<size_t>(k)] += w * gray_light_[Code(at, k)];
  } else {
    acc[static_cast<size_t>(c)] += w * stripe3_light_[Code(at, c)];
  }
}

template <int N>
Light<N> DisplayLight::ShadeAreaN(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const {
  const double x0 = fx - 0.5 * wx, x1 = fx + 0.5 * wx, y0 = fy - 0.5 * wy, y1 = fy + 0.5 * wy;
  // Tiny boxes, boxes that reach past the display's edge and huge ones (far away: many display pixels per
  // sample, where the image content aliases anyway) are point-sampled.
  if (!(wx > 1e-3 && wy > 1e-3) || wx > 16 || wy > 16 || x0 < 0 || y0 < 0 || x1 >= image_.width ||
      y1 >= image_.height) {
    return ShadePointN<N>(fx, fy);
  }
  const auto overlap = [](double a0, double a1, double b0, double b1) {
    return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
  };
  const int i0 = static_cast<int>(x0), i1 = static_cast<int>(x1);
  const int j0 = static_cast<int>(y0), j1 = static_cast<int>(y1);
  std::array<double, N> light{};
  Light<N> out;
  const double area = (x1 - x0) * (y1 - y0);
  if (psf_x > kStructureBlurredPx && psf_y > kStructureBlurredPx) {
    // Each pixel's mean light (pixel_mean_light_, or channel_mean_light_ of its codes), weighted by its share of
    // the box.
    for (int j = j0; j <= j1; ++j) {
      const double oy = overlap(y0, y1, j, j + 1);
      const size_t row = static_cast<size_t>(j) * image_.width;
      for (int i = i0; i <= i1; ++i) {
        const double w = overlap(x0, x1, i, i + 1) * oy;
        if constexpr (N == 1) {
          light[0] += w * pixel_mean_light_[row + static_cast<size_t>(i)];
        } else {
          const size_t at = (row + static_cast<size_t>(i)) * channels_;
          for (int c = 0; c < N; ++c) light[static_cast<size_t>(c)] += w * channel_mean_light_[Code(at, c)];
        }
      }
    }
    for (int c = 0; c < N; ++c) out[static_cast<size_t>(c)] = static_cast<float>(light[static_cast<size_t>(c)] / area);
    return out;
  }
  double lit_area = 0;
  for (int j = j0; j <= j1; ++j) {
    const double oy = overlap(y0, y1, j + 0.5 - half_fill_, j + 0.5 + half_fill_);
    if (oy <= 0) continue;
    const size_t row = static_cast<size_t>(j) * image_.width;
    for (int i = i0; i <= i1; ++i) {
      const size_t at = (row + static_cast<size_t>(i)) * channels_;
      if (!stripes_) {
        const double ox = overlap(x0, x1, i + 0.5 - half_fill_, i + 0.5 + half_fill_);
        if (ox <= 0) continue;
        Add<N>(light, ox * oy, at, -1);
        lit_area += ox * oy;
        continue;
      }
      for (int stripe = 0; stripe < 3; ++stripe) {
        const double ox = overlap(x0, x1, i + (stripe + 0.5 - half_fill_) / 3, i + (stripe + 0.5 + half_fill_) / 3);
        if (ox <= 0) continue;
        Add<N>(light, ox * oy, at, stripe_colour_[static_cast<size_t>(stripe)]);
        lit_area += ox * oy;
      }
    }
  }
  for (int c = 0; c < N; ++c) {
    out[static_cast<size_t>(c)] = static_cast<float>((light[static_cast<size_t>(c)] + black_ * (area - lit_area)) / area);
  }
  return out;
}

template <int N>
Light<N> DisplayLight::ShadePointN(double fx_full, double fy_full) const {
  Light<N> out;
  out.fill(black_);
  // Truncation is the floor for the non-negative values that reach it (std::floor is a call without SSE4.1).
  const int i = static_cast<int>(fx_full), j = static_cast<int>(fy_full);
  const double fx = fx_full - i, fy = fy_full - j;
  if (std::abs(fy - 0.5) > half_fill_) return out;
  const size_t at = (static_cast<size_t>(j) * image_.width + static_cast<size_t>(i)) * channels_;
  if (!stripes_) {
    if (std::abs(fx - 0.5) > half_fill_) return out;
    if constexpr (N == 1) {
      out[0] = GrayLight(at);
    } else {
      for (int c = 0; c < 3; ++c) out[static_cast<size_t>(c)] = gray_light_[Code(at, c)];
    }
    return out;
  }
  // Three stripes left to right; a monochrome sensor weights them by luma, scaled so white stays 1, a colour
  // sensor sees the stripe in its channel only.
  const int stripe = std::min(2, static_cast<int>(fx * 3));
  const double local = fx * 3 - stripe;
  if (std::abs(local - 0.5) > half_fill_) return out;
  const int colour = stripe_colour_[static_cast<size_t>(stripe)];
  if constexpr (N == 1) {
    out[0] = stripe_light_[static_cast<size_t>(colour)][Code(at, colour)];
  } else {
    out.fill(0.0f);
    out[static_cast<size_t>(colour)] = stripe3_light_[Code(at, colour)];
  }
  return out;
}

template Light<1> DisplayLight::ShadePointN<1>(double, double) const;
template Light<3> DisplayLight::ShadePointN<3>(double, double) const;
template Light<1> DisplayLight::ShadeAreaN<1>(double, double, double, double, double, double) const;
template Light<3> DisplayLight::ShadeAreaN<3>(double, double, double, double, double, double) const;

float DisplayLight::GrayLight(size_t at) const {
  if (channels_ == 1) return gray_light_[image_.pixels[at]];
  const int n = std::min(channels_, 3);
  float sum = 0;
  for (int c = 0; c < n; ++c) sum += gray_light_[image_.pixels[at + static_cast<size_t>(c)]];
  return sum / static_cast<float>(n);
}

double PanelLuminance(PanelAngular panel, double angle_deg) {
  static constexpr double kAngles[5] = {0, 30, 45, 60, 90};
  static constexpr double kTable[3][5] = {{1, 0.85, 0.70, 0.50, 0}, {1, 0.75, 0.50, 0.30, 0}, {1, 0.90, 0.80, 0.65, 0}};
  if (panel == PanelAngular::kNone) return 1;
  const double* table = kTable[static_cast<int>(panel) - 1];
  const double a = std::clamp(std::abs(angle_deg), 0.0, 90.0);
  int i = 0;
  while (i < 3 && a > kAngles[i + 1]) ++i;
  const double f = (a - kAngles[i]) / (kAngles[i + 1] - kAngles[i]);
  return (1 - f) * table[i] + f * table[i + 1];
}

namespace {

// The trace of TraceRadiance (N = 1) and TraceColour (N = 3: with `terms` and `depth`).
template <int N>
cv::Mat Trace(const SyntheticScene& s, const Image8& display, const RayGrid& rays, int64_t* refined_rays,
              const ColourTerms* terms, cv::Mat* depth) {
  const Landing landing(s, display);
  const DisplayLight light(s.display, display, N);
  // The optics' blur as a Gaussian sigma, camera px (a disc of radius r: r / 2). The colour chain: the optics'
  // Gaussian in focus (defocus only widens it).
  double psf_sigma_px = 0;
  if (N == 3) {
    psf_sigma_px = s.imaging.blur_px;
  } else if (s.optics.blur == Blur::kGaussian) {
    psf_sigma_px = s.optics.blur_px;
  } else if (s.optics.blur == Blur::kDisc) {
    psf_sigma_px = 0.5 * s.optics.blur_px;
  }
  const int width = s.camera.width, height = s.camera.height;
  const int n = s.optics.supersample;
  const bool point_samples = s.optics.sampling == Sampling::kPoint;  // no footprint (a stress condition)
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
  cv::Mat radiance = NewLargeMat(height, width, CV_MAKETYPE(CV_32F, N));
  if (depth) *depth = NewLargeMat(height, width, CV_32F);
  std::atomic<int64_t> refined_total{0};
  ParallelRows(height, [&](int y) {
    thread_local std::vector<Eigen::Vector2d> nodes;
    thread_local std::vector<Eigen::Vector3d> row_dirs;
    // Per sample row of this camera row: display coordinates of every sample (NaN off the display) and the
    // radiance of the samples that miss the display. One extra sample row (a camera pixel below) when n = 1, for
    // the vertical footprint.
    const int sample_rows = std::max(n, 2);
    thread_local std::vector<double> fxs, fys;
    thread_local std::vector<float> others, depths, luminances;
    // Sized, not refilled per row (that was 0.5 MB of memset per row at 24 MP, issue 18): the loop below writes
    // fxs everywhere, fys on every hit and others on every miss, and reads fys / others only there (a neighbour's
    // stale fys goes with its NaN fxs, which makes the footprint NaN and the sample a point sample).
    fxs.resize(static_cast<size_t>(sample_rows) * samples_x);
    fys.resize(fxs.size());
    others.resize(fxs.size());
    // The colour chain's depth and panel luminance per camera pixel, from its first sample that hits the screen
    // or bezel: both vary slowly across the image (the angle by ~0.01 deg per px), and a quarter of the samples'
    // geometry is a fifth of the trace's time saved.
    if (terms) {
      depths.assign(static_cast<size_t>(width), std::numeric_limits<float>::quiet_NaN());
      luminances.assign(static_cast<size_t>(width), 1.0f);
    }
    int64_t refined = 0, unused_refined = 0;
    SurfaceIntersector::HitGeometry hit;
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
        const size_t at = base + static_cast<size_t>(sx), px = static_cast<size_t>(sx / n);
        const bool want_geometry = terms && b < n && std::isnan(depths[px]);
        double fx = 0, fy = 0;
        float other = 0;
        // Directions have camera z = 1, so the hit's ray parameter is its depth along the optical axis.
        if (landing.Hit((1 - f) * row_dirs[i] + f * row_dirs[i + 1], b < n ? &refined : &unused_refined, &fx, &fy,
                        &other, want_geometry ? &hit : nullptr)) {
          fxs[at] = fx;
          fys[at] = fy;
        } else {
          fxs[at] = std::numeric_limits<double>::quiet_NaN();
          others[at] = other;
        }
        if (want_geometry && !std::isnan(hit.t)) {
          depths[px] = static_cast<float>(hit.t);
          luminances[px] = terms->Luminance(hit.cos_incidence);
        }
      }
    }
    // Footprint of a sample in display px: the bounding box of the parallelogram spanned by the differences to
    // the neighbouring samples across (dx) and down (dy); one-sided at the ends, point samples where a
    // neighbour is off the display.
    float* row = radiance.ptr<float>(y);
    std::fill(row, row + width * N, 0.0f);
    for (int b = 0; b < n; ++b) {
      const size_t base = static_cast<size_t>(b) * samples_x;
      const size_t below = static_cast<size_t>(b + 1 < sample_rows ? b + 1 : b - 1) * samples_x;
      for (int sx = 0; sx < samples_x; ++sx) {
        const size_t at = base + static_cast<size_t>(sx);
        const double fx = fxs[at];
        Light<N> value;
        if (std::isnan(fx)) {
          value.fill(others[at]);
        } else {
          const size_t left = sx > 0 ? at - 1 : at, right = sx + 1 < samples_x ? at + 1 : at;
          const double span = static_cast<double>(right - left);
          const double dxx = (fxs[right] - fxs[left]) / span, dxy = (fys[right] - fys[left]) / span;
          const size_t v = below + static_cast<size_t>(sx);
          const double dyx = fxs[v] - fx, dyy = fys[v] - fys[at];
          const double wx = std::abs(dxx) + std::abs(dyx), wy = std::abs(dxy) + std::abs(dyy);
          // The PSF in display px: footprints are per sample (1/n camera px).
          const double psf_x = psf_sigma_px * n * wx, psf_y = psf_sigma_px * n * wy;
          value = point_samples || std::isnan(wx) || std::isnan(wy)
                      ? light.template ShadePointN<N>(fx, fys[at])
                      : light.template ShadeAreaN<N>(fx, fys[at], wx, wy, psf_x, psf_y);
          if (terms) {
            const float reflection = terms->Reflection(fx, fys[at]);
            const float luminance = luminances[static_cast<size_t>(sx / n)];
            for (float& c : value) c = c * luminance + reflection;
          }
        }
        float* out = row + (sx / n) * N;
        if constexpr (N == 1) {
          out[0] += value[0];
        } else {
          // R, G, B to OpenCV's B, G, R.
          out[0] += value[2];
          out[1] += value[1];
          out[2] += value[0];
        }
      }
    }
    const float scale = 1.0f / static_cast<float>(n * n);
    for (int x = 0; x < width * N; ++x) row[x] *= scale;
    if (depth) std::copy(depths.begin(), depths.end(), depth->ptr<float>(y));
    refined_total += refined;
  });
  *refined_rays = refined_total;
  return radiance;
}

}  // namespace

cv::Mat TraceRadiance(const SyntheticScene& s, const Image8& display, const RayGrid& rays, int64_t* refined_rays) {
  return Trace<1>(s, display, rays, refined_rays, nullptr, nullptr);
}

ColourTrace TraceColour(const SyntheticScene& s, const Image8& display, const RayGrid& rays) {
  const ColourTerms terms(s);
  ColourTrace out;
  out.radiance = Trace<3>(s, display, rays, &out.refined_rays, &terms, &out.depth_mm);
  return out;
}

}  // namespace curvecheck::synth_internal
