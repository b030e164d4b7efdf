#include "capture/synthetic_camera.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>

#include "core/config.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"
#include "render/pattern.h"

namespace curvecheck {
namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
constexpr double kRadPerDeg = std::numbers::pi / 180;

Eigen::Vector3d Vec3(const ConfigMap& c, const std::string& key) {
  const std::vector<double> v = c.Numbers(key, 3);
  return {v[0], v[1], v[2]};
}

// The true monitor as a Monitor (its own curvature; same size and pixel grid as the nominal one).
Monitor TrueAsMonitor(const SyntheticScene& s) {
  Monitor m = s.monitor;
  m.curvature_per_mm = s.truth.curvature_per_mm;
  return m;
}

// Catmull-Rom weights for fraction f.
Eigen::Vector4d CubicWeights(double f) {
  const double f2 = f * f, f3 = f2 * f;
  return {-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f, 0.5 * f3 - 0.5 * f2};
}

template <typename F>
void ParallelRows(int rows, const F& body) {
  const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int y = t; y < rows; y += threads) body(y);
    });
  }
  for (auto& th : pool) th.join();
}

}  // namespace

Eigen::Matrix3d TrueMonitor::Rotation() const {
  const Eigen::Vector3d r = rotation_deg * kRadPerDeg;
  // Lean tilts the top (+y) toward the viewer (+z): a rotation about x by -lean.
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x() - lean_deg * kRadPerDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

double TrueMonitor::DeviationMm(const Eigen::Vector2d& uv) const {
  double d = 0;
  for (const Bump& b : bumps) {
    const double du = (uv.x() - b.u) / b.sigma_u, dv = (uv.y() - b.v) / b.sigma_v;
    d += b.height_mm * std::exp(-0.5 * (du * du + dv * dv));
  }
  return d;
}

Eigen::Matrix3d ScreenFromCamLookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& look_at,
                                    const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (look_at - position).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  if (!x.allFinite() || x.norm() < 0.5) {
    throw Error("camera", "the up vector is parallel to the viewing direction", "give another up vector");
  }
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return r;
}

SyntheticScene SceneFromConfig(const ConfigMap& c, const std::filesystem::path& scene_dir) {
  c.RejectUnknownKeys({"format", "name", "monitor", "camera", "true_monitor", "display", "optics", "sensor"});
  if (c.Has("format") && c.String("format") != "curvecheck.scene/1") {
    c.Fail("format", "is not 'curvecheck.scene/1'", "this version reads curvecheck.scene/1");
  }
  SyntheticScene s;
  const std::string monitor_spec = c.String("monitor");
  const std::filesystem::path monitor_path = scene_dir / monitor_spec;
  s.monitor = LoadMonitor(std::filesystem::exists(monitor_path) ? monitor_path.string() : monitor_spec);
  s.truth.curvature_per_mm = s.monitor.curvature_per_mm;

  const ConfigMap cam = c.Map("camera");
  cam.RejectUnknownKeys({"model", "position_mm", "look_at_mm", "up"});
  s.camera_model_path = cam.String("model");
  s.camera = ReadCameraModel(scene_dir / s.camera_model_path);
  s.camera_position_in_screen = Vec3(cam, "position_mm");
  const Eigen::Vector3d look_at = cam.Has("look_at_mm") ? Vec3(cam, "look_at_mm") : ScreenCentreInScreen(s.monitor);
  const Eigen::Vector3d up = cam.Has("up") ? Vec3(cam, "up") : Eigen::Vector3d::UnitY();
  s.screen_from_cam = ScreenFromCamLookAt(s.camera_position_in_screen, look_at, up);

  if (c.Has("true_monitor")) {
    const ConfigMap t = c.Map("true_monitor");
    t.RejectUnknownKeys({"radius_mm", "translation_mm", "rotation_deg", "lean_deg", "bumps"});
    if (t.Has("radius_mm")) {
      s.truth.curvature_per_mm = t.IsWord("radius_mm", "flat") ? 0.0 : 1.0 / t.PositiveNumber("radius_mm");
    }
    if (t.Has("translation_mm")) s.truth.translation_mm = Vec3(t, "translation_mm");
    if (t.Has("rotation_deg")) s.truth.rotation_deg = Vec3(t, "rotation_deg");
    if (t.Has("lean_deg")) s.truth.lean_deg = t.Number("lean_deg");
    if (t.Has("bumps")) {
      for (const ConfigMap& b : t.MapList("bumps")) {
        b.RejectUnknownKeys({"u", "v", "sigma_u", "sigma_v", "height_mm"});
        TrueMonitor::Bump bump;
        bump.u = b.Number("u");
        bump.v = b.Number("v");
        bump.sigma_u = b.PositiveNumber("sigma_u");
        bump.sigma_v = b.PositiveNumber("sigma_v");
        bump.height_mm = b.Number("height_mm");
        s.truth.bumps.push_back(bump);
      }
    }
    Monitor check = s.monitor;
    check.curvature_per_mm = s.truth.curvature_per_mm;
    check.Check(c.source() + " (true_monitor)");
  }
  if (c.Has("display")) {
    const ConfigMap d = c.Map("display");
    d.RejectUnknownKeys({"fill_factor", "rgb_stripes", "gamma", "black", "bezel_mm", "bezel", "room"});
    if (d.Has("fill_factor")) s.display.fill_factor = d.PositiveNumber("fill_factor");
    if (d.Has("rgb_stripes")) s.display.rgb_stripes = d.IsWord("rgb_stripes", "true");
    if (d.Has("gamma")) s.display.gamma = d.PositiveNumber("gamma");
    if (d.Has("black")) s.display.black = d.Number("black");
    if (d.Has("bezel_mm")) s.display.bezel_mm = d.Number("bezel_mm");
    if (d.Has("bezel")) s.display.bezel = d.Number("bezel");
    if (d.Has("room")) s.display.room = d.Number("room");
    if (s.display.fill_factor > 1) d.Fail("fill_factor", "is above 1", "give the emitting fraction, 0..1");
  }
  if (c.Has("optics")) {
    const ConfigMap o = c.Map("optics");
    o.RejectUnknownKeys({"supersample", "blur", "blur_px", "vignetting", "exposure"});
    if (o.Has("supersample")) s.optics.supersample = o.PositiveInt("supersample");
    if (o.Has("blur")) s.optics.blur = o.String("blur");
    if (o.Has("blur_px")) s.optics.blur_px = o.Number("blur_px");
    if (o.Has("vignetting")) s.optics.vignetting = o.Number("vignetting");
    if (o.Has("exposure")) s.optics.exposure = o.PositiveNumber("exposure");
    if (s.optics.blur != "none" && s.optics.blur != "gaussian" && s.optics.blur != "disc") {
      o.Fail("blur", "is not none, gaussian or disc", "choose one");
    }
    if (s.optics.supersample > 8) o.Fail("supersample", "is above 8", "use 1..8 rays per pixel per axis");
  }
  if (c.Has("sensor")) {
    const ConfigMap n = c.Map("sensor");
    n.RejectUnknownKeys({"gamma", "full_well_e", "read_noise_e", "noise", "seed", "bits"});
    if (n.Has("gamma")) s.sensor.gamma = n.PositiveNumber("gamma");
    if (n.Has("full_well_e")) s.sensor.full_well_e = n.PositiveNumber("full_well_e");
    if (n.Has("read_noise_e")) s.sensor.read_noise_e = n.Number("read_noise_e");
    if (n.Has("noise")) s.sensor.noise = n.IsWord("noise", "true");
    if (n.Has("seed")) s.sensor.seed = static_cast<uint64_t>(n.Number("seed"));
    if (n.Has("bits")) s.sensor.bits = n.PositiveInt("bits");
    if (s.sensor.bits != 8 && s.sensor.bits != 16) n.Fail("bits", "is not 8 or 16", "choose 8 or 16");
  }
  CheckViewpoint(s.monitor, s.camera_position_in_screen, c.source() + " (camera.position_mm)");
  return s;
}

SyntheticScene LoadScene(const std::filesystem::path& path) {
  return SceneFromConfig(ConfigMap::Load(path), path.parent_path());
}

Eigen::Vector3d TrueSurfacePointInScreen(const SyntheticScene& s, const Eigen::Vector2d& uv, Eigen::Vector3d* normal) {
  const Monitor mt = TrueAsMonitor(s);
  const Eigen::Vector3d n_true = SurfaceNormalFromUv(mt, uv);
  const Eigen::Vector3d p_true = SurfacePointFromUv(mt, uv) - ScreenCentreInScreen(mt) + s.truth.DeviationMm(uv) * n_true;
  const Eigen::Matrix3d r = s.truth.Rotation();
  if (normal) *normal = r * n_true;  // ignores the slope of the deviation field (smooth, small)
  return ScreenCentreInScreen(s.monitor) + s.truth.translation_mm + r * p_true;
}

RayGrid::RayGrid(const CameraModel& camera, double spacing_px, double dense_px)
    : spacing_(spacing_px), dense_spacing_(dense_px) {
  // Nodes from -2 spacings to beyond the far edge so that every pixel has its 4 x 4 neighbourhood.
  nx_ = static_cast<int>(std::ceil((camera.width + 1) / spacing_)) + 4;
  ny_ = static_cast<int>(std::ceil((camera.height + 1) / spacing_)) + 4;
  std::vector<Eigen::Vector2d> q;
  q.reserve(static_cast<size_t>(nx_) * ny_);
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) q.push_back(Node(i, j));
  }
  const std::vector<Eigen::Vector3d> v = UnprojectPixels(camera, q);
  normalized_.resize(v.size());
  for (size_t k = 0; k < v.size(); ++k) {
    if (!(v[k].z() > 0.05)) {
      throw Error("camera model", fmt::format("{} sees rays at more than 87 deg from its axis", camera.lensmodel),
                  "the synthetic camera supports lenses with a field of view below 174 deg");
    }
    normalized_[k] = Eigen::Vector2f(static_cast<float>(v[k].x() / v[k].z()), static_cast<float>(v[k].y() / v[k].z()));
  }
  dense_nx_ = static_cast<int>(std::ceil(camera.width / dense_spacing_)) + 2;
  dense_ny_ = static_cast<int>(std::ceil(camera.height / dense_spacing_)) + 2;
  dense_.resize(static_cast<size_t>(dense_nx_) * dense_ny_);
  for (int j = 0; j < dense_ny_; ++j) {
    for (int i = 0; i < dense_nx_; ++i) {
      dense_[static_cast<size_t>(j) * dense_nx_ + i] = Bicubic({i * dense_spacing_ - 0.5, j * dense_spacing_ - 0.5});
    }
  }
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

double RayGrid::MeasureErrorPx(const CameraModel& camera, int samples, uint64_t seed) const {
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
  for (int k = 0; k < samples; ++k) worst = std::max(worst, (back[static_cast<size_t>(k)] - q[static_cast<size_t>(k)]).norm());
  return worst;
}

namespace {

// Radiance (relative to a full white display pixel) seen along a ray in the screen frame.
struct Tracer {
  const SyntheticScene& s;
  const Image8& display;
  Monitor true_monitor;
  Eigen::Matrix3d true_from_nominal;  // rotation
  Eigen::Vector3d origin_true_centre;  // camera position in the true centre frame
  std::vector<float> linear;           // display code -> linear light, per channel value 0..255
  bool deviated;

  Tracer(const SyntheticScene& scene, const Image8& img) : s(scene), display(img) {
    true_monitor = TrueAsMonitor(s);
    true_from_nominal = s.truth.Rotation().transpose();
    origin_true_centre =
        true_from_nominal * (s.camera_position_in_screen - ScreenCentreInScreen(s.monitor) - s.truth.translation_mm);
    linear.resize(256);
    for (int c = 0; c < 256; ++c) {
      linear[static_cast<size_t>(c)] = static_cast<float>(s.display.black + (1 - s.display.black) * std::pow(c / 255.0, s.display.gamma));
    }
    deviated = !s.truth.bumps.empty();
  }

  float Radiance(const Eigen::Vector3d& dir_screen) const {
    const Eigen::Vector3d d = true_from_nominal * dir_screen;
    const Eigen::Vector3d origin = origin_true_centre + ScreenCentreInScreen(true_monitor);
    const std::optional<SurfaceHit> hit = IntersectSurface(true_monitor, origin, d);
    if (!hit) return static_cast<float>(s.display.room);
    Eigen::Vector2d uv = hit->uv;
    if (deviated) {
      // Newton steps onto the deviated surface: offset(p) - deviation(uv(p)) = 0 along the ray, with the
      // offset's derivative n . d (the deviation's own slope is neglected: the field is smooth).
      double t = hit->distance;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d p = origin + t * d;
        const Eigen::Vector2d puv = UvFromSurfacePoint(true_monitor, p);
        const Eigen::Vector3d on = SurfacePointFromUv(true_monitor, puv);
        const Eigen::Vector3d n = SurfaceNormalFromUv(true_monitor, puv);
        const double g = n.dot(p - on) - s.truth.DeviationMm(puv);
        const double nd = n.dot(d);
        if (nd == 0) break;
        t -= g / nd;
      }
      uv = UvFromSurfacePoint(true_monitor, origin + t * d);
    }
    const Monitor& m = s.monitor;
    const Eigen::Vector2d px = DisplayPxFromUv(m, uv);
    const double fx_full = px.x() + 0.5, fy_full = px.y() + 0.5;
    const int i = static_cast<int>(std::floor(fx_full)), j = static_cast<int>(std::floor(fy_full));
    if (i < 0 || j < 0 || i >= m.width_px || j >= m.height_px) {
      const double bu = 2 * s.display.bezel_mm / m.width_mm, bv = 2 * s.display.bezel_mm / m.height_mm;
      const bool on_bezel = std::abs(uv.x()) <= 1 + bu && std::abs(uv.y()) <= 1 + bv;
      return static_cast<float>(on_bezel ? s.display.bezel : s.display.room);
    }
    const double fx = fx_full - i, fy = fy_full - j;
    const double half_fill = 0.5 * s.display.fill_factor;
    const size_t at = (static_cast<size_t>(j) * display.width + static_cast<size_t>(i)) * display.channels;
    if (std::abs(fy - 0.5) > half_fill) return static_cast<float>(s.display.black);
    if (!s.display.rgb_stripes) {
      if (std::abs(fx - 0.5) > half_fill) return static_cast<float>(s.display.black);
      double sum = 0;
      for (int c = 0; c < display.channels && c < 3; ++c) sum += linear[display.pixels[at + static_cast<size_t>(c)]];
      return static_cast<float>(sum / std::min(display.channels, 3));
    }
    // Stripes R, G, B left to right; a monochrome sensor weights them by luma, scaled so white stays 1.
    const int stripe = std::min(2, static_cast<int>(fx * 3));
    const double local = fx * 3 - stripe;
    if (std::abs(local - 0.5) > half_fill) return static_cast<float>(s.display.black);
    static constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
    // Image8 colour is BGR(A): R is channel 2.
    const int channel = display.channels >= 3 ? 2 - stripe : 0;
    return static_cast<float>(3 * kLuma[stripe] * linear[display.pixels[at + static_cast<size_t>(channel)]]);
  }
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
  auto t0 = Clock::now();
  const RayGrid rays(s.camera, ray_grid_px);
  photo.timing.rays_ms = MsSince(t0);

  t0 = Clock::now();
  const Tracer tracer(s, display);
  const int n = s.optics.supersample;
  cv::Mat radiance(photo.height, photo.width, CV_32F);
  ParallelRows(photo.height, [&](int y) {
    float* row = radiance.ptr<float>(y);
    for (int x = 0; x < photo.width; ++x) {
      double sum = 0;
      for (int b = 0; b < n; ++b) {
        for (int a = 0; a < n; ++a) {
          const Eigen::Vector2d q(x + (a + 0.5) / n - 0.5, y + (b + 0.5) / n - 0.5);
          sum += tracer.Radiance(s.screen_from_cam * rays.Ray(q));
        }
      }
      row[x] = static_cast<float>(sum / (n * n));
    }
  });
  photo.timing.rays = static_cast<int64_t>(photo.width) * photo.height * n * n;
  photo.timing.trace_ms = MsSince(t0);

  t0 = Clock::now();
  if (s.optics.blur == "gaussian" && s.optics.blur_px > 0) {
    cv::GaussianBlur(radiance, radiance, cv::Size(0, 0), s.optics.blur_px, s.optics.blur_px, cv::BORDER_REPLICATE);
  } else if (s.optics.blur == "disc" && s.optics.blur_px > 0) {
    const int r = static_cast<int>(std::ceil(s.optics.blur_px));
    cv::Mat kernel = cv::Mat::zeros(2 * r + 1, 2 * r + 1, CV_32F);
    cv::circle(kernel, cv::Point(r, r), static_cast<int>(std::lround(s.optics.blur_px)), cv::Scalar(1), cv::FILLED);
    kernel /= cv::sum(kernel)[0];
    cv::filter2D(radiance, radiance, -1, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  }
  photo.timing.optics_ms = MsSince(t0);

  t0 = Clock::now();
  const double cx = 0.5 * (photo.width - 1), cy = 0.5 * (photo.height - 1), r2_corner = cx * cx + cy * cy;
  const double max_code = s.sensor.bits == 16 ? 65535.0 : 255.0;
  photo.pixels.resize(static_cast<size_t>(photo.width) * photo.height);
  ParallelRows(photo.height, [&](int y) {
    std::mt19937_64 rng(s.sensor.seed * 1000003ull + static_cast<uint64_t>(y));
    std::normal_distribution<double> normal(0, 1);
    const float* row = radiance.ptr<float>(y);
    for (int x = 0; x < photo.width; ++x) {
      const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2_corner;
      double v = row[x] * s.optics.exposure * (1 - s.optics.vignetting * r2);
      if (s.sensor.noise) {
        // Poisson-Gaussian: shot noise of the collected electrons (Gaussian approximation above 20 e, Poisson
        // below) plus read noise.
        const double electrons = std::max(0.0, v * s.sensor.full_well_e);
        double e = electrons > 20 ? electrons + std::sqrt(electrons) * normal(rng)
                                  : static_cast<double>(std::poisson_distribution<int>(electrons)(rng));
        e += s.sensor.read_noise_e * normal(rng);
        v = e / s.sensor.full_well_e;
      }
      v = std::clamp(v, 0.0, 1.0);
      if (s.sensor.gamma != 1) v = std::pow(v, 1 / s.sensor.gamma);
      photo.pixels[static_cast<size_t>(y) * photo.width + static_cast<size_t>(x)] =
          static_cast<uint16_t>(std::lround(v * max_code));
    }
  });
  photo.timing.sensor_ms = MsSince(t0);
  return photo;
}

nlohmann::json TruthJson(const SyntheticScene& s, const std::vector<Feature>& features) {
  nlohmann::json j;
  j["format"] = "curvecheck.truth/1";
  const TrueMonitor& t = s.truth;
  nlohmann::json bumps = nlohmann::json::array();
  for (const auto& b : t.bumps) {
    bumps.push_back({{"u", b.u}, {"v", b.v}, {"sigma_u", b.sigma_u}, {"sigma_v", b.sigma_v}, {"height_mm", b.height_mm}});
  }
  j["true_monitor"] = {{"radius_mm", t.curvature_per_mm == 0 ? nlohmann::json("flat") : nlohmann::json(1 / t.curvature_per_mm)},
                       {"translation_mm", {t.translation_mm.x(), t.translation_mm.y(), t.translation_mm.z()}},
                       {"rotation_deg", {t.rotation_deg.x(), t.rotation_deg.y(), t.rotation_deg.z()}},
                       {"lean_deg", t.lean_deg},
                       {"bumps", bumps}};
  const Eigen::Vector3d& c = s.camera_position_in_screen;
  nlohmann::json rot = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) rot.push_back({s.screen_from_cam(r, 0), s.screen_from_cam(r, 1), s.screen_from_cam(r, 2)});
  j["camera"] = {{"model", s.camera_model_path},
                 {"lensmodel", s.camera.lensmodel},
                 {"intrinsics", s.camera.intrinsics},
                 {"imagersize", {s.camera.width, s.camera.height}},
                 {"position_mm", {c.x(), c.y(), c.z()}},
                 {"screen_from_cam", rot}};
  nlohmann::json out = nlohmann::json::array();
  const Eigen::Matrix3d cam_from_screen = s.screen_from_cam.transpose();
  for (const Feature& f : features) {
    nlohmann::json e = {{"id", f.id}};
    bool visible = f.visible && f.display_px.has_value();
    if (f.display_px) {
      const Eigen::Vector2d uv = UvFromDisplayPx(s.monitor, *f.display_px);
      Eigen::Vector3d normal;
      const Eigen::Vector3d p = TrueSurfacePointInScreen(s, uv, &normal);
      const Eigen::Vector3d p_cam = cam_from_screen * (p - c);
      e["point_mm"] = {p.x(), p.y(), p.z()};
      visible = visible && p_cam.z() > 0 && normal.dot(c - p) > 0;
      if (p_cam.z() > 0) {
        const Eigen::Vector2d q = ProjectPoint(s.camera, p_cam);
        e["image_px"] = {q.x(), q.y()};
        visible = visible && q.x() >= -0.5 && q.y() >= -0.5 && q.x() <= s.camera.width - 0.5 &&
                  q.y() <= s.camera.height - 0.5;
      } else {
        e["image_px"] = nullptr;
      }
    }
    e["visible"] = visible;
    out.push_back(e);
  }
  j["features"] = out;
  return j;
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
