#include "synth/ray_grid.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>
#include <string>
#include <utility>

#include "core/error.h"
#include "synth/parallel_rows.h"

namespace curvecheck {
namespace {

// Catmull-Rom weights for fraction f.
Eigen::Vector4d CubicWeights(double f) {
  const double f2 = f * f, f3 = f2 * f;
  return {-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f, 0.5 * f3 - 0.5 * f2};
}

}  // namespace

RayGrid::RayGrid(const CameraModel& camera, double spacing_px, double dense_px, const LensMisfit* misfit)
    : spacing_(spacing_px), dense_spacing_(dense_px) {
  // Nodes from -2 spacings to beyond the far edge so that every pixel has its 4 x 4 neighbourhood.
  nx_ = static_cast<int>(std::ceil((camera.width + 1) / spacing_)) + 4;
  ny_ = static_cast<int>(std::ceil((camera.height + 1) / spacing_)) + 4;
  normalized_.resize(static_cast<size_t>(nx_) * ny_);
  // mrcal's unprojection is iterative for most models: one row per call, all cores.
  synth_internal::ParallelRows(ny_, [&](int j) {
    std::vector<Eigen::Vector2d> q;
    for (int i = 0; i < nx_; ++i) q.push_back(misfit ? misfit->ModelPixelOf(Node(i, j)) : Node(i, j));
    const std::vector<Eigen::Vector3d> v = UnprojectPixels(camera, q);
    for (int i = 0; i < nx_; ++i) {
      const Eigen::Vector3d& r = v[static_cast<size_t>(i)];
      if (!(r.z() > 0.05)) {
        throw Error("camera model", fmt::format("{} sees rays at more than 87 deg from its axis", camera.lensmodel),
                    "the synthetic camera supports lenses with a field of view below 174 deg");
      }
      normalized_[static_cast<size_t>(j) * nx_ + static_cast<size_t>(i)] =
          Eigen::Vector2f(static_cast<float>(r.x() / r.z()), static_cast<float>(r.y() / r.z()));
    }
  });
  dense_nx_ = static_cast<int>(std::ceil(camera.width / dense_spacing_)) + 2;
  dense_ny_ = static_cast<int>(std::ceil(camera.height / dense_spacing_)) + 2;
  dense_.resize(static_cast<size_t>(dense_nx_) * dense_ny_);
  synth_internal::ParallelRows(dense_ny_, [&](int j) {
    for (int i = 0; i < dense_nx_; ++i) {
      dense_[static_cast<size_t>(j) * dense_nx_ + i] = Bicubic({i * dense_spacing_ - 0.5, j * dense_spacing_ - 0.5});
    }
  });
}

void RayGrid::RowNodes(double y_px, std::vector<Eigen::Vector2d>* nodes) const {
  const double gy = (y_px + 0.5) / dense_spacing_;
  const int j = std::clamp(static_cast<int>(gy), 0, dense_ny_ - 2);
  const double fy = gy - j;
  nodes->resize(static_cast<size_t>(dense_nx_));
  const Eigen::Vector2d* top = &dense_[static_cast<size_t>(j) * dense_nx_];
  const Eigen::Vector2d* bottom = top + dense_nx_;
  for (int i = 0; i < dense_nx_; ++i) (*nodes)[static_cast<size_t>(i)] = (1 - fy) * top[i] + fy * bottom[i];
}

void RayGrid::DenseColumn(double x_px, int* i, double* f) const {
  const double gx = (x_px + 0.5) / dense_spacing_;
  *i = std::clamp(static_cast<int>(gx), 0, dense_nx_ - 2);
  *f = gx - *i;
}

Eigen::Vector2d RayGrid::Node(int i, int j) const { return {(i - 2) * spacing_ - 0.5, (j - 2) * spacing_ - 0.5}; }

Eigen::Vector3d RayGrid::Ray(const Eigen::Vector2d& q) const {
  const double gx = (q.x() + 0.5) / dense_spacing_, gy = (q.y() + 0.5) / dense_spacing_;
  const int i = std::clamp(static_cast<int>(gx), 0, dense_nx_ - 2), j = std::clamp(static_cast<int>(gy), 0, dense_ny_ - 2);
  const double fx = gx - i, fy = gy - j;
  const size_t k = static_cast<size_t>(j) * dense_nx_ + static_cast<size_t>(i);
  const Eigen::Vector2d top = (1 - fx) * dense_[k] + fx * dense_[k + 1];
  const Eigen::Vector2d bottom = (1 - fx) * dense_[k + dense_nx_] + fx * dense_[k + dense_nx_ + 1];
  const Eigen::Vector2d n = (1 - fy) * top + fy * bottom;
  return {n.x(), n.y(), 1.0};
}

Eigen::Vector2d RayGrid::Bicubic(const Eigen::Vector2d& q) const {
  const double gx = (q.x() + 0.5) / spacing_ + 2, gy = (q.y() + 0.5) / spacing_ + 2;
  const int i = std::clamp(static_cast<int>(std::floor(gx)), 1, nx_ - 3);
  const int j = std::clamp(static_cast<int>(std::floor(gy)), 1, ny_ - 3);
  const Eigen::Vector4d wx = CubicWeights(gx - i), wy = CubicWeights(gy - j);
  Eigen::Vector2d n = Eigen::Vector2d::Zero();
  for (int b = 0; b < 4; ++b) {
    Eigen::Vector2d row = Eigen::Vector2d::Zero();
    for (int a = 0; a < 4; ++a) {
      row += wx[a] * normalized_[static_cast<size_t>(j - 1 + b) * nx_ + static_cast<size_t>(i - 1 + a)].cast<double>();
    }
    n += wy[b] * row;
  }
  return n;
}

double RayGrid::MeasureErrorPx(const CameraModel& camera, int samples, uint64_t seed,
                               const LensMisfit* misfit) const {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-0.5, camera.width - 0.5), uy(-0.5, camera.height - 0.5);
  std::vector<Eigen::Vector2d> q;
  std::vector<Eigen::Vector3d> p;
  for (int k = 0; k < samples; ++k) {
    q.emplace_back(ux(rng), uy(rng));
    p.push_back(Ray(q.back()) * 1000.0);
  }
  const std::vector<Eigen::Vector2d> back = ProjectPoints(camera, p);
  double worst = 0;
  for (int k = 0; k < samples; ++k) {
    const Eigen::Vector2d b = misfit ? misfit->TrueImageOf(back[static_cast<size_t>(k)]) : back[static_cast<size_t>(k)];
    worst = std::max(worst, (b - q[static_cast<size_t>(k)]).norm());
  }
  return worst;
}

std::shared_ptr<const RayGrid> SharedRayGrid(const CameraModel& camera, double spacing_px, bool* from_cache,
                                             const LensMisfit* misfit) {
  static std::mutex mutex;
  static std::vector<std::pair<std::string, std::shared_ptr<const RayGrid>>> cache;  // most recent last
  std::string key = fmt::format("{} {}x{} {:a}", camera.lensmodel, camera.width, camera.height, spacing_px);
  for (double p : camera.intrinsics) key += fmt::format(" {:a}", p);
  if (misfit) key += " " + misfit->Key();
  if (from_cache) *from_cache = false;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it) {
      if (it->first == key) {
        auto entry = *it;
        cache.erase(it);
        cache.push_back(entry);
        if (from_cache) *from_cache = true;
        return entry.second;
      }
    }
  }
  // Built outside the lock (it takes all cores); two threads asking for a new lens at once both build it.
  auto grid = std::make_shared<const RayGrid>(camera, spacing_px, 4, misfit);
  const std::lock_guard<std::mutex> lock(mutex);
  cache.emplace_back(key, grid);
  if (cache.size() > 4) cache.erase(cache.begin());
  return grid;
}

}  // namespace curvecheck
