#include "detect/moire.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "core/stats.h"

namespace curvecheck {

void MoireOptions::Check(const std::string& where) const {
  const auto range = [&](const char* name, double v, double lo, double hi, const char* fix) {
    RequireInRange(where, name, v, lo, hi, fix);
  };
  range("patch_px", patch_px, 16, 256, "use 16..256 px, e.g. 32");
  range("max_patches", max_patches, 1, 1e6, "use at least 1, e.g. 64");
  range("min_contrast", min_contrast, 0, 1, "use a fraction of the white level, e.g. 0.02");
  range("min_peak_to_floor", min_peak_to_floor, 1, 1e9, "use a power ratio >= 1, e.g. 10");
  range("residual_contrast", residual_contrast, 1e-6, 1, "use a fraction of the white level, e.g. 0.005");
  range("residual_texture", residual_texture, 1e-6, 1, "use a fraction of the white level, e.g. 0.02");
  range("texture_limit", texture_limit, residual_texture, 1e9, "use a fraction of the white level at least "
        "residual_texture, e.g. 0.05");
}

double MoireFilterSigmaPx(double period_px, double contrast, double residual_contrast) {
  if (!(period_px > 0) || !(contrast > residual_contrast) || !(residual_contrast > 0)) return 0;
  // exp(-2 pi^2 sigma^2 f^2) = residual / contrast.
  return std::sqrt(std::log(contrast / residual_contrast) / 2) * period_px / M_PI;
}

double TextureFilterSigmaPx(double texture, double residual_texture) {
  if (!(texture > residual_texture) || !(residual_texture > 0)) return 0;
  // A Gaussian of sigma leaves white noise 1 / (2 sqrt(pi) sigma) of its standard deviation (sum of the kernel's
  // squares, 1 / (4 pi sigma^2) in two dimensions).
  return texture / (2 * std::sqrt(M_PI) * residual_texture);
}

MoireMeasure MeasureMoire(const cv::Mat& photo_gray, const MoireOptions& o) {
  o.Check("moire options");
  if (photo_gray.empty() || photo_gray.channels() != 1) {
    throw Error("photo", fmt::format("is a {}x{} image with {} channel(s)", photo_gray.cols, photo_gray.rows,
                                     photo_gray.channels()),
                "give a gray photo (ReadPhotoGray)");
  }
  MoireMeasure m;
  const int n = o.patch_px;
  if (photo_gray.cols < 2 * n || photo_gray.rows < 2 * n) return m;
  const cv::Mat& photo = photo_gray;

  // Bright areas: the photo averaged over blocks of n/4 px (INTER_AREA: long enough to average strong moire
  // away), the patch's minimum there above the bright level (core/stats.h WhiteLevel, kBrightOfWhite).
  const int block = std::max(1, n / 4);
  const cv::Size coarse_size(photo.cols / block, photo.rows / block);
  cv::Mat coarse;
  if (photo.cols % block == 0 && photo.rows % block == 0) {
    // Whole blocks (INTER_AREA's integer-factor path: each output is its own block's mean): in strips of whole
    // blocks converted to float one at a time, the same numbers as converting the whole photo, without its
    // 96 MB float copy at 24 MP (a sixth of `analyze`'s time in a profile, issue 18).
    coarse.create(coarse_size, CV_32F);
    const int strip_rows = block * std::max(1, 512 / block);
    cv::Mat strip;
    for (int y = 0; y < photo.rows; y += strip_rows) {
      const int rows = std::min(strip_rows, photo.rows - y);
      photo.rowRange(y, y + rows).convertTo(strip, CV_32F);
      cv::Mat out = coarse.rowRange(y / block, (y + rows) / block);
      cv::resize(strip, out, out.size(), 0, 0, cv::INTER_AREA);
    }
  } else {
    cv::Mat photo_f;
    photo.convertTo(photo_f, CV_32F);
    cv::resize(photo_f, coarse, coarse_size, 0, 0, cv::INTER_AREA);
  }
  const double white = WhiteLevel(std::vector<float>(coarse.begin<float>(), coarse.end<float>()));
  if (!(white > 0)) return m;
  std::vector<cv::Point> corners;  // top-left of each bright patch
  for (int y = 0; y + n <= photo.rows; y += n) {
    for (int x = 0; x + n <= photo.cols; x += n) {
      const cv::Rect cell(x / block, y / block, n / block, n / block);
      if ((cell & cv::Rect(0, 0, coarse.cols, coarse.rows)) != cell) continue;
      double lo = 0;
      cv::minMaxLoc(coarse(cell), &lo);
      if (lo > kBrightOfWhite * white) corners.emplace_back(x, y);
    }
  }
  if (corners.empty()) return m;
  const size_t step = (corners.size() + static_cast<size_t>(o.max_patches) - 1) / static_cast<size_t>(o.max_patches);

  cv::Mat window(n, n, CV_32F);
  double sum_w2 = 0;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const double w = (0.5 - 0.5 * std::cos(2 * M_PI * (x + 0.5) / n)) * (0.5 - 0.5 * std::cos(2 * M_PI * (y + 0.5) / n));
      window.at<float>(y, x) = static_cast<float>(w);
      sum_w2 += w * w;
    }
  }
  cv::Mat power = cv::Mat::zeros(n, n, CV_64F);
  double level = 0;
  for (size_t i = 0; i < corners.size(); i += step) {
    cv::Mat patch;
    photo(cv::Rect(corners[i], cv::Size(n, n))).convertTo(patch, CV_32F);
    const double mean = cv::mean(patch)[0];
    level += mean;
    patch -= mean;
    patch = patch.mul(window);
    cv::Mat spectrum;
    cv::dft(patch, spectrum, cv::DFT_COMPLEX_OUTPUT);
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const cv::Vec2f c = spectrum.at<cv::Vec2f>(y, x);
        power.at<double>(y, x) += static_cast<double>(c[0]) * c[0] + static_cast<double>(c[1]) * c[1];
      }
    }
    ++m.patches;
  }
  power /= m.patches;
  m.white_level = level / m.patches;

  // Bins by signed frequency index k in (-n/2, n/2]; the half plane ky > 0 or (ky == 0, kx > 0) (a real image's
  // spectrum is symmetric), without the lowest 2 bins of either axis.
  const auto wrap = [n](int k) { return k > n / 2 ? k - n : k; };
  std::vector<double> bins;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const int kx = wrap(x), ky = wrap(y);
      if (std::max(std::abs(kx), std::abs(ky)) <= 2) continue;
      if (ky < 0 || (ky == 0 && kx < 0)) continue;
      const double p = power.at<double>(y, x);
      bins.push_back(p);
    }
  }
  std::nth_element(bins.begin(), bins.begin() + static_cast<std::ptrdiff_t>(bins.size() / 2), bins.end());
  const double floor = bins[bins.size() / 2];
  const auto at = [&](int kx, int ky) { return power.at<double>(((ky % n) + n) % n, ((kx % n) + n) % n); };
  // Every local maximum (3 x 3) of the half plane, as a component with its contrast.
  for (int ky = 0; ky <= n / 2; ++ky) {
    for (int kx = -n / 2 + 1; kx <= n / 2; ++kx) {
      if (std::max(std::abs(kx), std::abs(ky)) <= 2 || (ky == 0 && kx < 0)) continue;
      const double p = at(kx, ky);
      bool peak = true;
      for (int dy = -1; dy <= 1 && peak; ++dy) {
        for (int dx = -1; dx <= 1 && peak; ++dx) {
          if ((dx != 0 || dy != 0) && at(kx + dx, ky + dy) > p) peak = false;
        }
      }
      if (!peak) continue;
      double lobe = 0;
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) lobe += at(kx + dx, ky + dy) - floor;
      }
      MoireComponent c;
      c.frequency_x = static_cast<double>(kx) / n;
      c.frequency_y = static_cast<double>(ky) / n;
      c.period_px = 1 / std::hypot(c.frequency_x, c.frequency_y);
      const double amplitude = 2 * std::sqrt(std::max(0.0, lobe) / (static_cast<double>(n) * n * sum_w2));
      c.contrast = m.white_level > 0 ? amplitude / m.white_level : 0;
      c.peak_to_floor = floor > 0 ? p / floor : (p > 0 ? 1e9 : 0);
      if (c.contrast >= o.min_contrast && c.peak_to_floor >= o.min_peak_to_floor) m.components.push_back(c);
      if (c.contrast > m.contrast) {
        m.contrast = c.contrast;
        m.period_px = c.period_px;
        m.frequency_x = c.frequency_x;
        m.frequency_y = c.frequency_y;
        m.peak_to_floor = c.peak_to_floor;
      }
    }
  }
  std::sort(m.components.begin(), m.components.end(),
            [](const MoireComponent& a, const MoireComponent& b) { return a.contrast > b.contrast; });
  m.present = !m.components.empty();
  for (const MoireComponent& c : m.components) {
    const double sigma = MoireFilterSigmaPx(c.period_px, c.contrast, o.residual_contrast);
    if (sigma > m.needed_sigma_px) m.needed_sigma_px = sigma, m.limiting_period_px = c.period_px;
  }

  // The broadband texture (moire.h): white at the spectrum's floor. The floor is the median of an average of
  // `patches` exponential bin powers (a Gamma of shape k = patches), whose mean is about k / (k - 1/3) times it.
  if (m.white_level > 0 && floor > 0) {
    const double k = m.patches;
    m.texture = std::sqrt(floor * k / (k - 1.0 / 3.0) / sum_w2) / m.white_level;
    if (m.texture >= o.texture_limit) m.texture_sigma_px = TextureFilterSigmaPx(m.texture, o.residual_texture);
  }
  return m;
}

}  // namespace curvecheck
