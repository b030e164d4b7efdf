#include "render/antialias_reference.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/correction.h"
#include "core/error.h"
#include "core/parallel.h"

namespace curvecheck {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A convex polygon of at most 4 + 4 vertices (a quadrilateral clipped by the four sides of a square).
struct Polygon {
  std::array<Eigen::Vector2d, 12> v;
  int n = 0;
};

// Sutherland-Hodgman: the part of `in` where sign * (p[axis] - limit) <= 0.
Polygon Clip(const Polygon& in, int axis, double limit, double sign) {
  Polygon out;
  for (int i = 0; i < in.n; ++i) {
    const Eigen::Vector2d& a = in.v[static_cast<size_t>(i)];
    const Eigen::Vector2d& b = in.v[static_cast<size_t>((i + 1) % in.n)];
    const double da = sign * (a[axis] - limit), db = sign * (b[axis] - limit);
    if (da <= 0) out.v[static_cast<size_t>(out.n++)] = a;
    if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
      out.v[static_cast<size_t>(out.n++)] = a + (b - a) * (da / (da - db));
    }
  }
  return out;
}

double Area(const Polygon& p) {
  double twice = 0;
  for (int i = 0; i < p.n; ++i) {
    const Eigen::Vector2d& a = p.v[static_cast<size_t>(i)];
    const Eigen::Vector2d& b = p.v[static_cast<size_t>((i + 1) % p.n)];
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * std::abs(twice);
}

enum class Label { kBlack, kWhite, kSurround };

Label CellLabel(const PatternCells& c, long col, long row) {
  if (col < 0 || row < 0 || col >= c.width || row >= c.height) return Label::kSurround;
  return c.Value(static_cast<int>(col), static_cast<int>(row)) >= 128 ? Label::kWhite : Label::kBlack;
}

// Encoded code value (0..255, float) of a linear value for a display of gamma `gamma`, as the shaders do.
double Encode(double linear, double gamma) {
  const double v = std::clamp(linear, 0.0, 1.0);
  return 255.0 * (gamma == 1 ? v : std::pow(v, 1.0 / gamma));
}

double SurroundLinear(const RenderOptions& o) { return std::pow(o.surround_code / 255.0, o.display_gamma); }

// The crop whose centre pixel is nearest the feature.
int CropStart(double feature_px, int crop_px) {
  return static_cast<int>(std::lround(feature_px - 0.5 * (crop_px - 1)));
}

}  // namespace

double ReferenceCrop::LinearMean(const Eigen::Vector2d& centre_px, double surround_linear) const {
  const double n = samples_per_axis;
  const double u0 = (centre_px.x() - 0.5 - origin_px.x()) * n, v0 = (centre_px.y() - 0.5 - origin_px.y()) * n;
  const double u1 = u0 + n, v1 = v0 + n;
  constexpr double kSlack = 1e-9;
  if (!(u0 >= -kSlack && v0 >= -kSlack && u1 <= strata_w + kSlack && v1 <= strata_h + kSlack)) {
    throw Error("antialias reference",
                fmt::format("pixel square at ({}, {}) lies outside the reference of {} (margin {} px)",
                            centre_px.x(), centre_px.y(), feature_id, margin_px),
                "render the reference with a larger margin");
  }
  const int stride = strata_w + 1;
  // The integral image at fractional stratum coordinates: bilinear interpolation, which is exact for the
  // integral of strata of uniform value (partial strata counted by area).
  auto at = [&](const std::vector<double>& f, double u, double v) {
    const int k = std::clamp(static_cast<int>(std::floor(u)), 0, strata_w - 1);
    const int l = std::clamp(static_cast<int>(std::floor(v)), 0, strata_h - 1);
    const double fu = u - k, fv = v - l;
    const size_t i = static_cast<size_t>(l) * static_cast<size_t>(stride) + static_cast<size_t>(k);
    const size_t s = static_cast<size_t>(stride);
    return (1 - fv) * ((1 - fu) * f[i] + fu * f[i + 1]) + fv * ((1 - fu) * f[i + s] + fu * f[i + s + 1]);
  };
  auto box = [&](const std::vector<double>& f) {
    return at(f, u1, v1) - at(f, u0, v1) - at(f, u1, v0) + at(f, u0, v0);
  };
  return (box(white_integral) + surround_linear * box(surround_integral)) / (n * n);
}

ReferenceCrop RenderReferenceCrop(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                  const Feature& feature, int crop_px, int samples_per_axis, double margin_px,
                                  const Eigen::Vector2d& pattern_shift_px) {
  const std::string where = "antialias reference";
  if (!feature.display_px) throw Error(where, fmt::format("feature {} has no display position", feature.id));
  if (crop_px < 2 || crop_px > 256) throw Error(where, fmt::format("crop of {} px", crop_px), "use 2..256");
  if (samples_per_axis < 1 || samples_per_axis > 256) {
    throw Error(where, fmt::format("{} samples per axis", samples_per_axis), "use 1..256");
  }
  if (!(std::isfinite(margin_px) && margin_px >= 0 && margin_px <= 16)) {
    throw Error(where, fmt::format("margin of {} px", margin_px), "use 0..16");
  }
  if (!pattern_shift_px.allFinite()) throw Error(where, "the pattern shift is not finite");

  ReferenceCrop crop;
  crop.feature_id = feature.id;
  crop.feature_px = *feature.display_px;
  crop.x0 = CropStart(crop.feature_px.x(), crop_px);
  crop.y0 = CropStart(crop.feature_px.y(), crop_px);
  crop.size = crop_px;
  crop.samples_per_axis = samples_per_axis;
  crop.pattern_shift_px = pattern_shift_px;
  const int n = samples_per_axis;
  const int margin_strata = static_cast<int>(std::ceil(margin_px * n));
  crop.margin_px = static_cast<double>(margin_strata) / n;
  crop.origin_px = Eigen::Vector2d(crop.x0 - 0.5 - crop.margin_px, crop.y0 - 0.5 - crop.margin_px);
  crop.strata_w = crop.strata_h = crop_px * n + 2 * margin_strata;
  const int w = crop.strata_w, h = crop.strata_h;

  // Cell coordinates (col, row; row down) of the exact plane point of every stratum corner.
  const PatternCells& cells = pattern.cells;
  const size_t stride = static_cast<size_t>(w) + 1;
  std::vector<Eigen::Vector2d> corner(stride * (static_cast<size_t>(h) + 1));
  for (int q = 0; q <= h; ++q) {
    for (int p = 0; p <= w; ++p) {
      const Eigen::Vector2d display = crop.origin_px + Eigen::Vector2d(p, q) / n - pattern_shift_px;
      const auto ab = PatternFromDisplayPx(m, viewpoint, pattern.plane, display);
      corner[static_cast<size_t>(q) * stride + static_cast<size_t>(p)] =
          ab ? Eigen::Vector2d((ab->x() - cells.top_left_mm.x()) / cells.cell_mm,
                               (cells.top_left_mm.y() - ab->y()) / cells.cell_mm)
             : Eigen::Vector2d(kNaN, kNaN);
    }
  }

  // Shares of every stratum, accumulated into the integral images.
  crop.white_integral.assign(stride * (static_cast<size_t>(h) + 1), 0.0);
  crop.surround_integral.assign(crop.white_integral.size(), 0.0);
  std::vector<double> white_row(static_cast<size_t>(w)), surround_row(static_cast<size_t>(w));
  for (int q = 0; q < h; ++q) {
    for (int p = 0; p < w; ++p) {
      const size_t i = static_cast<size_t>(q) * stride + static_cast<size_t>(p);
      Polygon quad;
      quad.n = 4;
      quad.v = {corner[i], corner[i + 1], corner[i + stride + 1], corner[i + stride]};
      double white = 0, surround = 0;
      bool finite = true;
      long c_lo = std::numeric_limits<long>::max(), c_hi = std::numeric_limits<long>::min();
      long r_lo = c_lo, r_hi = c_hi;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d& v = quad.v[static_cast<size_t>(k)];
        if (!v.allFinite()) {
          finite = false;
          break;
        }
        const long c = static_cast<long>(std::floor(v.x())), r = static_cast<long>(std::floor(v.y()));
        c_lo = std::min(c_lo, c), c_hi = std::max(c_hi, c), r_lo = std::min(r_lo, r),
        r_hi = std::max(r_hi, r);
      }
      if (!finite) {
        surround = 1;  // a corner off the plane: the renderers draw the surround there
      } else if (c_lo == c_hi && r_lo == r_hi) {
        const Label label = CellLabel(cells, c_lo, r_lo);
        white = label == Label::kWhite ? 1 : 0;
        surround = label == Label::kSurround ? 1 : 0;
      } else {
        // The quad straddles cell edges: exact area of its part in every cell it touches.
        const double total = Area(quad);
        for (long r = r_lo; r <= r_hi; ++r) {
          for (long c = c_lo; c <= c_hi; ++c) {
            const Label label = CellLabel(cells, c, r);
            if (label == Label::kBlack) continue;
            Polygon part = Clip(quad, 0, static_cast<double>(c), -1);
            part = Clip(part, 0, static_cast<double>(c + 1), 1);
            part = Clip(part, 1, static_cast<double>(r), -1);
            part = Clip(part, 1, static_cast<double>(r + 1), 1);
            if (part.n < 3) continue;
            (label == Label::kWhite ? white : surround) += Area(part) / total;
          }
        }
      }
      white_row[static_cast<size_t>(p)] = white;
      surround_row[static_cast<size_t>(p)] = surround;
    }
    // Integral row q + 1 = row q + running sums of this stratum row.
    double run_white = 0, run_surround = 0;
    const size_t above = static_cast<size_t>(q) * stride, here = above + stride;
    for (int p = 0; p < w; ++p) {
      run_white += white_row[static_cast<size_t>(p)];
      run_surround += surround_row[static_cast<size_t>(p)];
      crop.white_integral[here + static_cast<size_t>(p) + 1] =
          crop.white_integral[above + static_cast<size_t>(p) + 1] + run_white;
      crop.surround_integral[here + static_cast<size_t>(p) + 1] =
          crop.surround_integral[above + static_cast<size_t>(p) + 1] + run_surround;
    }
  }
  return crop;
}

std::vector<ReferenceCrop> RenderReferenceCrops(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                                const Pattern& pattern, int crop_px, int samples_per_axis) {
  std::vector<const Feature*> selected;
  for (const Feature& f : pattern.features) {
    if (!f.visible || !f.display_px) continue;
    const int x0 = CropStart(f.display_px->x(), crop_px), y0 = CropStart(f.display_px->y(), crop_px);
    if (x0 < 0 || y0 < 0 || x0 + crop_px > m.width_px || y0 + crop_px > m.height_px) continue;
    selected.push_back(&f);
  }
  std::vector<ReferenceCrop> crops(selected.size());
  ParallelFor(static_cast<int>(selected.size()), [&](int i) {
    crops[static_cast<size_t>(i)] = RenderReferenceCrop(
        m, viewpoint, pattern, *selected[static_cast<size_t>(i)], crop_px, samples_per_axis);
  });
  return crops;
}

std::vector<float> ReferenceCodes(const ReferenceCrop& crop, const RenderOptions& options,
                                  const Eigen::Vector2d& shift_px) {
  options.Check("antialias reference");
  const double surround = SurroundLinear(options);
  std::vector<float> codes(static_cast<size_t>(crop.size) * static_cast<size_t>(crop.size));
  for (int j = 0; j < crop.size; ++j) {
    for (int i = 0; i < crop.size; ++i) {
      const Eigen::Vector2d centre = Eigen::Vector2d(crop.x0 + i, crop.y0 + j) - shift_px;
      codes[static_cast<size_t>(j) * static_cast<size_t>(crop.size) + static_cast<size_t>(i)] =
          static_cast<float>(Encode(crop.LinearMean(centre, surround), options.display_gamma));
    }
  }
  return codes;
}

FeatureBias EstimatePlacementBias(const ReferenceCrop& crop, const RenderOptions& options,
                                  const std::vector<float>& rendered) {
  options.Check("antialias reference");
  if (rendered.size() != static_cast<size_t>(crop.size) * static_cast<size_t>(crop.size)) {
    throw Error("antialias reference", fmt::format("rendered crop has {} values for a {} x {} crop",
                                                   rendered.size(), crop.size, crop.size));
  }
  const double surround = SurroundLinear(options), gamma = options.display_gamma;
  const double step = 1.0 / crop.samples_per_axis;  // gradient step: one stratum
  FeatureBias out;
  out.id = crop.feature_id;
  out.display_px = crop.feature_px;
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  auto code = [&](const Eigen::Vector2d& centre) { return Encode(crop.LinearMean(centre, surround), gamma); };
  auto within_margin = [&](const Eigen::Vector2d& s) {
    return s.cwiseAbs().maxCoeff() + step <= crop.margin_px;
  };
  auto sum_squares = [&](const Eigen::Vector2d& s) {
    double sum2 = 0;
    for (int j = 0; j < crop.size; ++j) {
      for (int i = 0; i < crop.size; ++i) {
        const double e =
            rendered[static_cast<size_t>(j) * static_cast<size_t>(crop.size) + static_cast<size_t>(i)] -
            code(Eigen::Vector2d(crop.x0 + i, crop.y0 + j) - s);
        sum2 += e * e;
      }
    }
    return sum2;
  };
  auto finish = [&](const Eigen::Vector2d& s, double sum2) {
    out.shift_px = s;
    out.rms_code = std::sqrt(sum2 / (crop.size * crop.size));
    return out;
  };
  constexpr int kMaxIterations = 100;
  constexpr double kConvergedPx = 1e-6;
  double cost = sum_squares(shift);
  for (out.iterations = 1; out.iterations <= kMaxIterations; ++out.iterations) {
    // rendered(x) ~ ref(x - shift - delta) ~ ref(x - shift) - grad ref(x - shift) . delta.
    Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (int j = 0; j < crop.size; ++j) {
      for (int i = 0; i < crop.size; ++i) {
        const Eigen::Vector2d at = Eigen::Vector2d(crop.x0 + i, crop.y0 + j) - shift;
        const Eigen::Vector2d dx(step, 0), dy(0, step);
        const Eigen::Vector2d grad((code(at + dx) - code(at - dx)) / (2 * step),
                                   (code(at + dy) - code(at - dy)) / (2 * step));
        const double e =
            rendered[static_cast<size_t>(j) * static_cast<size_t>(crop.size) + static_cast<size_t>(i)] -
            code(at);
        normal += grad * grad.transpose();
        rhs -= grad * e;
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(normal);
    if (!(eig.eigenvalues()(0) > 1e-9 * std::max(1.0, eig.eigenvalues()(1)))) {
      break;  // no texture in one direction: the shift is not determined
    }
    const Eigen::Vector2d delta = normal.ldlt().solve(rhs);
    if (!delta.allFinite()) break;
    // Backtracking: the code values are not smooth in the shift where an edge crosses into a black pixel
    // (linear^(1/gamma) has an infinite slope at 0), so a full Gauss-Newton step can overshoot.
    double t = 1;
    bool improved = false;
    Eigen::Vector2d candidate = shift;
    double candidate_cost = cost;
    for (int halvings = 0; halvings < 40 && t * delta.norm() >= 0.1 * kConvergedPx; ++halvings, t *= 0.5) {
      candidate = shift + t * delta;
      if (!within_margin(candidate)) continue;
      candidate_cost = sum_squares(candidate);
      if (candidate_cost <= cost) {
        improved = true;
        break;
      }
    }
    if (!improved) return finish(shift, cost);  // a minimum to within the step tolerance
    // Expansion: next to such a point the Gauss-Newton steps shrink geometrically while the cost keeps
    // falling; longer steps along the same direction reach it in a few iterations.
    for (int doublings = 0; t == 1 && doublings < 12; ++doublings) {
      const Eigen::Vector2d longer = shift + 2 * (candidate - shift);
      if (!within_margin(longer)) break;
      const double longer_cost = sum_squares(longer);
      if (!(longer_cost < candidate_cost)) break;
      candidate = longer;
      candidate_cost = longer_cost;
    }
    const double moved_px = (candidate - shift).norm();
    shift = candidate;
    cost = candidate_cost;
    if (moved_px < kConvergedPx) return finish(shift, cost);
  }
  out.iterations = std::min(out.iterations, kMaxIterations);
  out.shift_px = Eigen::Vector2d(kNaN, kNaN);
  out.rms_code = std::sqrt(cost / (crop.size * crop.size));
  return out;
}

std::vector<FeatureBias> MeasurePlacementBias(const std::vector<ReferenceCrop>& crops,
                                              const RenderOptions& options, const GrayImage& rendered) {
  std::vector<FeatureBias> out;
  out.reserve(crops.size());
  for (const ReferenceCrop& crop : crops) {
    if (crop.x0 < 0 || crop.y0 < 0 || crop.x0 + crop.size > rendered.width ||
        crop.y0 + crop.size > rendered.height) {
      throw Error("antialias reference",
                  fmt::format("crop of {} lies outside the {} x {} image", crop.feature_id, rendered.width,
                              rendered.height),
                  "measure an image of the monitor the references were rendered for");
    }
    std::vector<float> codes(static_cast<size_t>(crop.size) * static_cast<size_t>(crop.size));
    for (int j = 0; j < crop.size; ++j) {
      for (int i = 0; i < crop.size; ++i) {
        codes[static_cast<size_t>(j) * static_cast<size_t>(crop.size) + static_cast<size_t>(i)] =
            rendered.pixels[static_cast<size_t>(crop.y0 + j) * static_cast<size_t>(rendered.width) +
                            static_cast<size_t>(crop.x0 + i)];
      }
    }
    out.push_back(EstimatePlacementBias(crop, options, codes));
  }
  return out;
}

std::vector<FeatureBias> MeasurePlacementBias(const Monitor& m, const Eigen::Vector3d& viewpoint,
                                              const Pattern& pattern, const RenderOptions& options,
                                              const GrayImage& rendered, int crop_px, int samples_per_axis) {
  if (rendered.width != m.width_px || rendered.height != m.height_px) {
    throw Error("antialias reference", "image size does not match the monitor", "render for this monitor");
  }
  return MeasurePlacementBias(RenderReferenceCrops(m, viewpoint, pattern, crop_px, samples_per_axis), options,
                              rendered);
}

PlacementBiasSummary SummarizePlacementBias(const std::vector<FeatureBias>& biases) {
  PlacementBiasSummary s;
  double sum2_shift = 0, sum2_code = 0;
  for (const FeatureBias& b : biases) {
    if (!b.shift_px.allFinite()) {
      ++s.failed;
      continue;
    }
    ++s.features;
    s.mean_shift_px += b.shift_px;
    s.max_shift_px = std::max(s.max_shift_px, b.shift_px.norm());
    sum2_shift += b.shift_px.squaredNorm();
    sum2_code += b.rms_code * b.rms_code;
  }
  if (s.features > 0) {
    s.mean_shift_px /= s.features;
    s.rms_shift_px = std::sqrt(sum2_shift / s.features);
    s.rms_code = std::sqrt(sum2_code / s.features);
  }
  return s;
}

}  // namespace curvecheck
