#include "synth/imaging.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/large_buffer.h"
#include "synth/parallel_rows.h"
#include "synth/random.h"

namespace curvecheck::synth_internal {

double FocalLengthMm(const CameraModel& camera, const Imaging& imaging) {
  return camera.intrinsics.at(0) * imaging.pixel_pitch_um * 1e-3;
}

double DefocusSigmaPx(double depth_mm, double focus_mm, double focal_mm, double f_number, double pitch_um) {
  if (f_number <= 0 || !std::isfinite(depth_mm) || depth_mm <= 0 || focus_mm <= focal_mm) return 0;
  const double c_mm = focal_mm * focal_mm / f_number * std::abs(depth_mm - focus_mm) / (depth_mm * (focus_mm - focal_mm));
  return c_mm / 4 / (pitch_um * 1e-3);
}

void AddVeilingGlare(double glare, cv::Mat* radiance) {
  if (glare <= 0) return;
  const cv::Scalar mean = cv::mean(*radiance);
  *radiance += glare * mean;
}

namespace {

// A Gaussian blur of sigma px (replicated borders), as cv::GaussianBlur's kernel (8 sigma + 1 taps, sampled) but
// through cv::sepFilter2D, which OpenCV 4.6 vectorizes for float images (GaussianBlur took 20x longer on a
// 24 MP CV_32FC3 photo).
void Blur(const cv::Mat& in, double sigma, cv::Mat* out) {
  const int taps = cvRound(sigma * 8 + 1) | 1;
  const cv::Mat kernel = cv::getGaussianKernel(taps, sigma, CV_32F);
  cv::sepFilter2D(in, *out, -1, kernel, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
}

}  // namespace

int BlurBySigmaMap(const cv::Mat& sigma_px, cv::Mat* radiance) {
  double lo = 0, hi = 0;
  cv::minMaxLoc(sigma_px, &lo, &hi);
  if (hi <= 0) return 0;
  if (hi - lo < 1e-3 * hi) {
    cv::Mat blurred;
    Blur(*radiance, hi, &blurred);
    *radiance = blurred;
    return 1;
  }
  // Levels evenly spaced in log sigma, at most 25% apart.
  lo = std::max(lo, 0.05);
  const int steps = std::max(1, static_cast<int>(std::ceil(std::log(hi / lo) / std::log(1.25))));
  std::vector<double> levels;
  for (int k = 0; k <= steps; ++k) levels.push_back(lo * std::pow(hi / lo, static_cast<double>(k) / steps));
  // In place, by strips of rows run in parallel. A strip's input is its own rows (which only it writes, after
  // reading them) and `margin` rows (the kernel's reach) of its neighbours, taken from copies made before any
  // strip runs; at the image's top and bottom the input ends there, so the blur replicates the image's own edge.
  // Fresh full-size buffers cost more than the blur here (first-touch page faults: ~1 s per 300 MB on the
  // shared machine), so each thread reuses its strip buffers.
  const int channels = radiance->channels(), rows = radiance->rows;
  const int margin = static_cast<int>(std::ceil(4 * hi)) + 2, strip = std::max(128, margin);
  const int strips = (rows + strip - 1) / strip;
  std::vector<cv::Mat> top(static_cast<size_t>(strips)), bottom(static_cast<size_t>(strips));
  for (int k = 0; k < strips; ++k) {
    const int y0 = k * strip, y1 = std::min(rows, y0 + strip);
    top[static_cast<size_t>(k)] = radiance->rowRange(y0, std::min(y1, y0 + margin)).clone();
    bottom[static_cast<size_t>(k)] = radiance->rowRange(std::max(y0, y1 - margin), y1).clone();
  }
  ParallelRows(strips, [&](int k) {
    thread_local cv::Mat in, blurred, out;
    const int y0 = k * strip, y1 = std::min(rows, y0 + strip);
    std::vector<cv::Mat> parts;
    if (k > 0) parts.push_back(bottom[static_cast<size_t>(k) - 1]);
    parts.push_back(radiance->rowRange(y0, y1));
    if (k + 1 < strips) parts.push_back(top[static_cast<size_t>(k) + 1]);
    cv::vconcat(parts, in);
    const int first = k > 0 ? bottom[static_cast<size_t>(k) - 1].rows : 0;  // row y0 in `in`
    out.create(y1 - y0, radiance->cols, radiance->type());
    out.setTo(cv::Scalar::all(0));
    for (size_t l = 0; l < levels.size(); ++l) {
      // Hat weights in variance: 1 at this level, 0 at the neighbouring levels.
      const double v = levels[l] * levels[l];
      const double v_below = l > 0 ? levels[l - 1] * levels[l - 1] : -1;
      const double v_above = l + 1 < levels.size() ? levels[l + 1] * levels[l + 1] : -1;
      bool used = false;
      for (int y = y0; y < y1 && !used; ++y) {
        const float* s = sigma_px.ptr<float>(y);
        for (int x = 0; x < radiance->cols && !used; ++x) {
          const double s2 = static_cast<double>(s[x]) * s[x];
          used = (v_below < 0 || s2 > v_below) && (v_above < 0 || s2 < v_above);
        }
      }
      if (!used) continue;
      Blur(in, levels[l], &blurred);
      const double below_span = v_below < 0 ? 1 : v - v_below, above_span = v_above < 0 ? 1 : v_above - v;
      for (int y = y0; y < y1; ++y) {
        const float* s = sigma_px.ptr<float>(y);
        const float* b = blurred.ptr<float>(y - y0 + first);
        float* o = out.ptr<float>(y - y0);
        for (int x = 0; x < radiance->cols; ++x) {
          const double s2 = static_cast<double>(s[x]) * s[x];
          double w;
          if (s2 >= v) {
            w = v_above < 0 ? 1.0 : (v_above - s2) / above_span;
          } else {
            w = v_below < 0 ? 1.0 : (s2 - v_below) / below_span;
          }
          if (w <= 0) continue;
          const float wf = static_cast<float>(w);
          for (int c = 0; c < channels; ++c) o[x * channels + c] += wf * b[x * channels + c];
        }
      }
    }
    out.copyTo(radiance->rowRange(y0, y1));
  });
  return static_cast<int>(levels.size());
}

double VignettingGain(VignettingModel model, double ev, double r) {
  const double corner_gain = std::exp2(-ev);
  if (model == VignettingModel::kQuadratic) return 1 - (1 - corner_gain) * r * r;
  const double a = std::exp2(0.5 * ev) - 1;
  const double q = 1 + a * r * r;
  return 1 / (q * q);
}

cv::Mat ExposeRaw(const Imaging& g, const Sensor& sensor, const cv::Mat& radiance, const cv::Mat& storage) {
  const int width = radiance.cols, height = radiance.rows;
  const bool mosaic = g.cfa == ColourFilter::kRggb;
  cv::Mat raw = ReuseOrNewLargeMat(storage, height, width, mosaic ? CV_16U : CV_16UC3);
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1), r2_corner = cx * cx + cy * cy;
  const double full_well = g.full_well_e, dn_per_e = (std::exp2(g.raw_bits) - 1) / full_well;
  // VignettingGain's two models as functions of r^2 (no sqrt, no exp2 per site): cos4 1 / (1 + a r^2)^2,
  // quadratic 1 - b r^2.
  const bool cos4 = g.vignetting_model == VignettingModel::kCos4;
  const double a = std::exp2(0.5 * g.vignetting_ev) - 1, b = 1 - std::exp2(-g.vignetting_ev);
  ParallelRows(height, [&](int y) {
    // The temporal noise (field 0) and the PRNU pattern (field 1): one stream each per row, from (seed, row).
    SplitMix64 noise = RowStream(sensor.seed, y, 0), prnu = RowStream(sensor.seed, y, 1);
    const float* in = radiance.ptr<float>(y);
    uint16_t* out = raw.ptr<uint16_t>(y);
    const double dy2 = (y - cy) * (y - cy);
    // Channel (B 0, G 1, R 2) of each site: RGGB, R at even row and column.
    const int even_colour = y % 2 == 0 ? 2 : 1, odd_colour = y % 2 == 0 ? 1 : 0;
    for (int x = 0; x < width; ++x) {
      const double r2 = ((x - cx) * (x - cx) + dy2) / r2_corner, q = 1 + a * r2;
      const double gain = g.exposure * (cos4 ? 1 / (q * q) : 1 - b * r2) * full_well;
      const int c0 = mosaic ? (x % 2 == 0 ? even_colour : odd_colour) : 0, c1 = mosaic ? c0 + 1 : 3;
      for (int c = c0; c < c1; ++c) {
        double e = in[x * 3 + c] * gain;
        if (g.prnu > 0) e *= 1 + g.prnu * prnu.Normal();
        if (sensor.noise) e = NoisyElectrons(e, g.read_noise_e, noise);
        e = std::clamp(e, 0.0, full_well);
        out[mosaic ? x : x * 3 + c] = static_cast<uint16_t>(e * dn_per_e + 0.5);
      }
    }
  });
  return raw;
}

cv::Mat DemosaicRaw(const cv::Mat& raw, const Imaging& g, const cv::Mat& storage) {
  if (raw.channels() == 3) return raw;
  cv::Mat bgr = ReuseOrNewLargeMat(storage, raw.rows, raw.cols, CV_16UC3);  // cv::demosaicing keeps it
  switch (g.demosaic) {
    case Demosaic::kBilinear:
      cv::demosaicing(raw, bgr, cv::COLOR_BayerRGGB2BGR);
      break;
    case Demosaic::kEdgeAware:
      cv::demosaicing(raw, bgr, cv::COLOR_BayerRGGB2BGR_EA);
      break;
    case Demosaic::kVng: {
      const double max_dn = std::exp2(g.raw_bits) - 1;
      cv::Mat raw8, bgr8;
      raw.convertTo(raw8, CV_8U, 255.0 / max_dn);
      cv::demosaicing(raw8, bgr8, cv::COLOR_BayerRGGB2BGR_VNG);
      bgr8.convertTo(bgr, CV_16U, max_dn / 255.0);
      break;
    }
  }
  return bgr;
}

cv::Mat ToneMap8(const cv::Mat& dn, int raw_bits, ToneCurve tone) {
  const int levels = 1 << raw_bits;
  std::vector<uint8_t> lut(static_cast<size_t>(levels));
  for (int i = 0; i < levels; ++i) {
    const double x = static_cast<double>(i) / (levels - 1);
    const double y = tone == ToneCurve::kLinear ? x
                     : x <= 0.0031308       ? 12.92 * x
                                            : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
    lut[static_cast<size_t>(i)] = static_cast<uint8_t>(std::lround(std::clamp(y, 0.0, 1.0) * 255));
  }
  cv::Mat out = NewLargeMat(dn.rows, dn.cols, CV_8UC3);
  ParallelRows(dn.rows, [&](int y) {
    const uint16_t* in = dn.ptr<uint16_t>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int i = 0; i < dn.cols * 3; ++i) o[i] = lut[std::min<size_t>(in[i], lut.size() - 1)];
  });
  return out;
}

std::vector<uint8_t> EncodeJpeg(const cv::Mat& bgr8, int quality) {
  std::vector<uint8_t> bytes;
  if (!cv::imencode(".jpg", bgr8, bytes, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw Error("imaging.jpeg_quality", "OpenCV could not encode the photo as JPEG", "set jpeg_quality: 0");
  }
  return bytes;
}

cv::Mat DecodeJpeg(const std::vector<uint8_t>& jpeg, cv::Mat into) {
  cv::imdecode(jpeg, cv::IMREAD_COLOR, &into);
  if (into.empty()) throw Error("synthetic photo", "its own JPEG did not decode", "report this as a bug");
  return into;
}

}  // namespace curvecheck::synth_internal
