#include "synth/synthetic_camera.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <ctime>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>
#include <yaml-cpp/yaml.h>

#include "core/config.h"
#include "core/error.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"
#include "pattern/pattern.h"

namespace curvecheck {
namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
// CPU time of the whole process (all threads), ms.
double CpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}
constexpr double kRadPerDeg = std::numbers::pi / 180;

Eigen::Vector3d Vec3(const ConfigMap& c, const std::string& key) {
  const std::vector<double> v = c.Numbers(key, 3);
  return {v[0], v[1], v[2]};
}

// Catmull-Rom weights for fraction f.
Eigen::Vector4d CubicWeights(double f) {
  const double f2 = f * f, f3 = f2 * f;
  return {-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f, 0.5 * f3 - 0.5 * f2};
}

int ThreadCount() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

// body(y) for y in [0, rows) on all cores; rows are handed out in blocks of 4 as threads free up (rows that
// see only the room are cheaper than rows across the display).
template <typename F>
void ParallelRows(int rows, const F& body) {
  const int threads = ThreadCount();
  std::atomic<int> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto work = [&] {
    try {
      for (int y0 = next.fetch_add(4); y0 < rows; y0 = next.fetch_add(4)) {
        for (int y = y0; y < std::min(rows, y0 + 4); ++y) body(y);
      }
    } catch (...) {  // the first failure is rethrown on the calling thread; the others stop early
      next = rows;
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
  if (failure) std::rethrow_exception(failure);
}

// The true surface of TrueMonitor's header comment, in the true centre frame, with the maps between it, its
// upright (unleaned) cylinder and the nominal screen frame.
struct TrueGeometry {
  double k, half_w, half_h, cos_l, sin_l;
  Eigen::Matrix3d shear, upright_from_true, rotation;  // upright_from_true = shear^-1
  Eigen::Vector3d centre_in_screen;  // true screen centre in the nominal screen frame
  const TrueMonitor* truth;

  explicit TrueGeometry(const SyntheticScene& s) : truth(&s.truth) {
    k = s.truth.curvature_per_mm;
    half_w = 0.5 * s.monitor.width_mm;
    half_h = 0.5 * s.monitor.height_mm;
    const double l = s.truth.lean_deg * kRadPerDeg;
    cos_l = std::cos(l);
    sin_l = std::sin(l);
    shear = s.truth.Shear();
    upright_from_true = shear.inverse();
    rotation = s.truth.Rotation();
    centre_in_screen = ScreenCentreInScreen(s.monitor) + s.truth.translation_mm;
  }
  // phi = k s at u.
  double Phi(double u) const { return k * u * half_w; }
  // The leaned surface without deviation, C(u) + w a.
  Eigen::Vector3d BasePoint(const Eigen::Vector2d& uv) const {
    const double s = uv.x() * half_w, phi = k * s, h = Sinc(0.5 * phi), w = -uv.y() * half_h;
    return {s * Sinc(phi), w * cos_l, s * 0.5 * phi * h * h + w * sin_l};
  }
  // Unit normal of the leaned surface: dC/du x a = (-sin(phi) cos(l), -cos(phi) sin(l), cos(phi) cos(l)).
  Eigen::Vector3d Normal(const Eigen::Vector2d& uv) const {
    const double phi = Phi(uv.x());
    return Eigen::Vector3d(-std::sin(phi) * cos_l, -std::cos(phi) * sin_l, std::cos(phi) * cos_l).normalized();
  }
  Eigen::Vector3d Point(const Eigen::Vector2d& uv, Eigen::Vector3d* normal = nullptr) const {
    const Eigen::Vector3d n = Normal(uv);
    if (normal) *normal = n;
    return BasePoint(uv) + truth->DeviationMm(uv) * n;
  }
};

// atan(x) for |x| <= 1, within 1e-10 rad: reduced to |x| <= tan(pi/8) and summed as its odd series to x^21
// (the next term is below 0.4143^23 / 23 = 7e-11).
inline double FastAtan(double x) {
  constexpr double kTanPi8 = 0.41421356237309503;
  double offset = 0;
  if (x > kTanPi8) {
    offset = std::numbers::pi / 4;
    x = (x - 1) / (x + 1);
  } else if (x < -kTanPi8) {
    offset = -std::numbers::pi / 4;
    x = (x + 1) / (1 - x);
  }
  // Estrin's scheme (short dependency chains) for sum_n (-1)^n x2^n / (2n + 1), n = 0..10.
  const double x2 = x * x, x4 = x2 * x2, x8 = x4 * x4, x16 = x8 * x8;
  const double p01 = 1.0 - x2 / 3, p23 = 1.0 / 5 - x2 / 7, p45 = 1.0 / 9 - x2 / 11, p67 = 1.0 / 13 - x2 / 15;
  const double p89 = 1.0 / 17 - x2 / 19;
  const double p = (p01 + x4 * p23) + x8 * (p45 + x4 * p67) + x16 * (p89 + x4 * (1.0 / 21));
  return offset + x * p;
}

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

Eigen::Matrix3d TrueMonitor::Rotation() const {
  const Eigen::Vector3d r = rotation_deg * kRadPerDeg;
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Matrix3d TrueMonitor::Shear() const {
  // (x, w, z) upright -> (x, w cos(lambda), z + w sin(lambda)): the column through each point turns into the
  // axis a = (0, cos(lambda), sin(lambda)) while x and z stay, so rows keep their arcs.
  const double l = lean_deg * kRadPerDeg;
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, std::cos(l), 0, 0, std::sin(l), 1;
  return m;
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

namespace {

// The scene reader of both SceneFromConfig overloads. `scene_dir` null: the scene is in no folder, so its monitor
// is a preset name or a path as given, and `read_camera` reads the camera model it names.
SyntheticScene ReadScene(const ConfigMap& c, const std::filesystem::path* scene_dir,
                         const std::function<CameraModel(const std::string& model)>& read_camera) {
  c.RejectUnknownKeys({"format", "name", "monitor", "camera", "true_monitor", "display", "optics", "sensor"});
  if (c.Has("format") && c.String("format") != "curvecheck.scene/1") {
    c.Fail("format", "is not 'curvecheck.scene/1'", "this version reads curvecheck.scene/1");
  }
  SyntheticScene s;
  const std::string monitor_spec = c.String("monitor");
  const std::filesystem::path monitor_path = scene_dir ? *scene_dir / monitor_spec : std::filesystem::path();
  s.monitor = LoadMonitor(scene_dir && std::filesystem::exists(monitor_path) ? monitor_path.string() : monitor_spec);
  s.truth.curvature_per_mm = s.monitor.curvature_per_mm;

  const ConfigMap cam = c.Map("camera");
  cam.RejectUnknownKeys({"model", "position_mm", "look_at_mm", "up"});
  s.camera_model_path = cam.String("model");
  s.camera = read_camera(s.camera_model_path);
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
    if (t.Has("lean_deg")) {
      s.truth.lean_deg = t.Number("lean_deg");
      if (!(std::abs(s.truth.lean_deg) < 45)) t.Fail("lean_deg", "is not within +-45 deg", "give the axis tilt in degrees");
    }
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
    if (s.display.bezel_mm < 0) {
      d.Fail("bezel_mm", fmt::format("is {}, below zero", s.display.bezel_mm), "give 0 or more mm");
    }
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
    if (s.optics.blur_px < 0) o.Fail("blur_px", fmt::format("is {}, below zero", s.optics.blur_px), "give 0 or more px");
    if (s.optics.vignetting < 0 || s.optics.vignetting > 1) {
      o.Fail("vignetting", fmt::format("is {}, outside 0..1", s.optics.vignetting), "give the corner light loss, 0..1");
    }
  }
  if (c.Has("sensor")) {
    const ConfigMap n = c.Map("sensor");
    n.RejectUnknownKeys({"gamma", "full_well_e", "read_noise_e", "noise", "seed", "bits"});
    if (n.Has("gamma")) s.sensor.gamma = n.PositiveNumber("gamma");
    if (n.Has("full_well_e")) s.sensor.full_well_e = n.PositiveNumber("full_well_e");
    if (n.Has("read_noise_e")) s.sensor.read_noise_e = n.Number("read_noise_e");
    if (s.sensor.read_noise_e < 0) {
      n.Fail("read_noise_e", fmt::format("is {}, below zero", s.sensor.read_noise_e), "give 0 or more electrons");
    }
    if (n.Has("noise")) s.sensor.noise = n.IsWord("noise", "true");
    if (n.Has("seed")) {
      // A whole number that a double holds exactly; anything else (negative, fractional, 1e30) would be an
      // undefined conversion (found by fuzz_scene).
      const double seed = n.Number("seed");
      if (!(seed >= 0 && seed <= 9007199254740992.0 && seed == std::floor(seed))) {
        n.Fail("seed", fmt::format("is {}", seed), "give a whole number from 0 to 2^53");
      }
      s.sensor.seed = static_cast<uint64_t>(seed);
    }
    if (n.Has("bits")) s.sensor.bits = n.PositiveInt("bits");
    if (s.sensor.bits != 8 && s.sensor.bits != 16) n.Fail("bits", "is not 8 or 16", "choose 8 or 16");
  }
  CheckViewpoint(s.monitor, s.camera_position_in_screen, c.source() + " (camera.position_mm)");
  return s;
}

}  // namespace

SyntheticScene SceneFromConfig(const ConfigMap& c, const std::filesystem::path& scene_dir) {
  return ReadScene(c, &scene_dir, [&](const std::string& model) { return ReadCameraModel(scene_dir / model); });
}

SyntheticScene SceneFromConfig(const ConfigMap& c,
                               const std::function<CameraModel(const std::string& model)>& read_camera) {
  return ReadScene(c, nullptr, read_camera);
}

SyntheticScene LoadScene(const std::filesystem::path& path, const std::vector<std::string>& overrides) {
  if (overrides.empty()) return SceneFromConfig(ConfigMap::Load(path), path.parent_path());
  const ConfigMap original = ConfigMap::Load(path);  // syntax errors named with the file's lines
  YAML::Node root = YAML::LoadFile(path.string());
  for (const std::string& o : overrides) {
    const size_t eq = o.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error(o, "is not KEY=VALUE", "write e.g. optics.blur=none or true_monitor.lean_deg=0.5");
    }
    std::vector<std::string> keys;
    for (size_t start = 0, dot; start <= eq; start = dot + 1) {
      dot = std::min(o.find('.', start), eq);
      keys.push_back(o.substr(start, dot - start));
      if (keys.back().empty()) throw Error(o, "has an empty key", "write e.g. optics.blur=none");
    }
    YAML::Node node;
    node.reset(root);
    for (size_t i = 0; i + 1 < keys.size(); ++i) {
      if (node[keys[i]] && !node[keys[i]].IsMap()) {
        throw Error(o, fmt::format("'{}' is not a mapping in {}", keys[i], path.string()), "set a field inside it");
      }
      YAML::Node child = node[keys[i]];
      node.reset(child);
    }
    try {
      node[keys.back()] = YAML::Load(o.substr(eq + 1));
    } catch (const YAML::Exception& e) {
      throw Error(o, fmt::format("has a value that is not YAML ({})", e.msg), "quote it or fix its syntax");
    }
  }
  YAML::Emitter out;
  out << root;
  std::string source = path.string() + " with";
  for (const std::string& o : overrides) source += " " + o;
  return SceneFromConfig(ConfigMap::Parse(out.c_str(), source), path.parent_path());
}

CameraModel ScaledCamera(const CameraModel& camera, double scale) {
  if (!(scale > 0 && scale <= 1)) {
    throw Error("imager scale", fmt::format("{} is not in (0, 1]", scale), "give a fraction such as 0.5");
  }
  if (camera.lensmodel.rfind("LENSMODEL_CAHVOR", 0) == 0 || camera.intrinsics.size() < 4) {
    throw Error("imager scale", fmt::format("{} has no fx, fy, cx, cy core to scale", camera.lensmodel),
                "use the full imager with this lens model");
  }
  CameraModel c = camera;
  c.width = std::max(1, static_cast<int>(std::lround(camera.width * scale)));
  c.height = std::max(1, static_cast<int>(std::lround(camera.height * scale)));
  c.intrinsics[0] *= scale;
  c.intrinsics[1] *= scale;
  c.intrinsics[2] = (camera.intrinsics[2] + 0.5) * scale - 0.5;
  c.intrinsics[3] = (camera.intrinsics[3] + 0.5) * scale - 0.5;
  return c;
}

Eigen::Vector3d TrueSurfacePointInScreen(const SyntheticScene& s, const Eigen::Vector2d& uv, Eigen::Vector3d* normal) {
  const TrueGeometry g(s);
  Eigen::Vector3d n;
  const Eigen::Vector3d p = g.Point(uv, &n);  // the normal ignores the slope of the deviation field (smooth, small)
  if (normal) *normal = g.rotation * n;
  return g.centre_in_screen + g.rotation * p;
}

RayGrid::RayGrid(const CameraModel& camera, double spacing_px, double dense_px)
    : spacing_(spacing_px), dense_spacing_(dense_px) {
  // Nodes from -2 spacings to beyond the far edge so that every pixel has its 4 x 4 neighbourhood.
  nx_ = static_cast<int>(std::ceil((camera.width + 1) / spacing_)) + 4;
  ny_ = static_cast<int>(std::ceil((camera.height + 1) / spacing_)) + 4;
  normalized_.resize(static_cast<size_t>(nx_) * ny_);
  ParallelRows(ny_, [&](int j) {  // mrcal's unprojection is iterative for most models: one row per call, all cores
    std::vector<Eigen::Vector2d> q;
    for (int i = 0; i < nx_; ++i) q.push_back(Node(i, j));
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
  ParallelRows(dense_ny_, [&](int j) {
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

// SharedRayGrid with a flag: *cached is set when the table came from the cache.
std::shared_ptr<const RayGrid> SharedRayGrid(const CameraModel& camera, double spacing_px, const RayGrid** cached) {
  static std::mutex mutex;
  static std::vector<std::pair<std::string, std::shared_ptr<const RayGrid>>> cache;  // most recent last
  std::string key = fmt::format("{} {}x{} {:a}", camera.lensmodel, camera.width, camera.height, spacing_px);
  for (double p : camera.intrinsics) key += fmt::format(" {:a}", p);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it) {
      if (it->first == key) {
        auto entry = *it;
        cache.erase(it);
        cache.push_back(entry);
        *cached = entry.second.get();
        return entry.second;
      }
    }
  }
  // Built outside the lock (it takes all cores); two threads asking for a new lens at once both build it.
  auto grid = std::make_shared<const RayGrid>(camera, spacing_px);
  const std::lock_guard<std::mutex> lock(mutex);
  cache.emplace_back(key, grid);
  if (cache.size() > 4) cache.erase(cache.begin());
  return grid;
}

// Per-scene precomputation for the ray tracer. Rays are traced in the upright true centre frame (the true
// centre frame mapped through the inverse lean shear), where the true screen is the upright cylinder
// k (x^2 + z^2) = 2 z: the camera origin is transformed once, directions by one fixed 3 x 3, and the quadratic's
// constant term is the same for every ray. Surface coordinates come from the hit point without atan2: on the
// cylinder sin(phi) = k x and cos(phi) = 1 - k z, so phi = 2 atan(k x / (2 - k z)) (half-angle form).
struct Tracer {
  const SyntheticScene& s;
  const Image8& display;
  TrueGeometry geometry;
  Eigen::Matrix3d upright_from_cam;
  Eigen::Vector3d o;         // camera in the upright true centre frame
  double k, c_term;          // curvature; c = k (o_x^2 + o_z^2) - 2 o_z
  double u_from_s, u_from_phi, v_from_y;  // u = s / (W/2) = phi / (k W/2), v = -y / (H/2)
  double px_per_u, py_per_v;  // display px + 0.5 = (u + 1) px_per_u
  double bezel_u, bezel_v;    // half-extent of bezel + display in u, v
  float room, bezel, black;
  double half_fill;
  bool stripes;
  std::array<std::array<float, 256>, 3> stripe_light;  // luma-weighted linear light of stripe R, G, B per code
  std::array<float, 256> gray_light;                   // linear light per code (no stripes)
  // Mean light of each display pixel over its whole area (emitters at their light, black between them):
  // what ShadeArea uses where the optics blur the pixel structure away. Row-major, display size.
  std::vector<float> pixel_mean_light;
  int channels;
  struct Box {
    double u0, u1, v0, v1;
  };
  std::vector<Box> bump_support;  // where a bump's 4-sigma support (grown by the parallax of its height) lies

  Tracer(const SyntheticScene& scene, const Image8& img) : s(scene), display(img), geometry(scene) {
    const Eigen::Matrix3d true_from_screen = geometry.rotation.transpose();
    upright_from_cam = geometry.upright_from_true * true_from_screen * s.screen_from_cam;
    o = geometry.upright_from_true * true_from_screen * (s.camera_position_in_screen - geometry.centre_in_screen);
    k = geometry.k;
    c_term = k * (o.x() * o.x() + o.z() * o.z()) - 2 * o.z();
    const Monitor& m = s.monitor;
    u_from_s = 1 / geometry.half_w;
    u_from_phi = k == 0 ? 0.0 : 1 / (k * geometry.half_w);
    v_from_y = -1 / geometry.half_h;
    px_per_u = 0.5 * m.width_px;
    py_per_v = 0.5 * m.height_px;
    bezel_u = 1 + 2 * s.display.bezel_mm / m.width_mm;
    bezel_v = 1 + 2 * s.display.bezel_mm / m.height_mm;
    room = static_cast<float>(s.display.room);
    bezel = static_cast<float>(s.display.bezel);
    black = static_cast<float>(s.display.black);
    half_fill = 0.5 * s.display.fill_factor;
    if (s.optics.blur == "gaussian") psf_sigma_px = s.optics.blur_px;
    if (s.optics.blur == "disc") psf_sigma_px = 0.5 * s.optics.blur_px;
    stripes = s.display.rgb_stripes;
    channels = display.channels;
    static constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 256; ++c) {
      const double light = s.display.black + (1 - s.display.black) * std::pow(c / 255.0, s.display.gamma);
      for (int st = 0; st < 3; ++st) stripe_light[st][c] = static_cast<float>(3 * kLuma[st] * light);
      gray_light[c] = static_cast<float>(light);
    }
    const double fill_area = s.display.fill_factor * s.display.fill_factor;
    pixel_mean_light.resize(static_cast<size_t>(display.width) * display.height);
    for (size_t p = 0; p < pixel_mean_light.size(); ++p) {
      const size_t at = p * channels;
      double emitted = 0;
      if (!stripes) {
        emitted = GrayLight(at);
      } else {
        for (int stripe = 0; stripe < 3; ++stripe) {
          const int channel = channels >= 3 ? 2 - stripe : 0;
          emitted += stripe_light[stripe][display.pixels[at + static_cast<size_t>(channel)]] / 3.0;
        }
      }
      pixel_mean_light[p] = static_cast<float>(fill_area * emitted + (1 - fill_area) * s.display.black);
    }
    for (const TrueMonitor::Bump& b : s.truth.bumps) {
      // A ray meets the deviated surface at most |h| tan(incidence) from where it meets the base surface; 4 |h|
      // covers incidences up to 76 deg.
      const double grow_mm = 4 * std::abs(b.height_mm);
      const double gu = grow_mm / geometry.half_w, gv = grow_mm / geometry.half_h;
      bump_support.push_back({b.u - 4 * b.sigma_u - gu, b.u + 4 * b.sigma_u + gu, b.v - 4 * b.sigma_v - gv,
                              b.v + 4 * b.sigma_v + gv});
    }
  }

  // Radiance (relative to a full white display pixel) along the ray o + t d, d in the upright frame.
  // `refined` counts rays refined onto the deviation field.
  // Where the ray o + t d (d in the upright frame) meets the screen: true with the display pixel coordinates
  // (fx, fy) = ((u + 1) Nx/2, (v + 1) Ny/2) (pixel i spans [i, i + 1)) when it lands on the display; false with
  // the radiance of what it sees otherwise (bezel, room). `refined` counts rays refined onto the deviation field.
  bool Hit(const Eigen::Vector3d& d, int64_t* refined, double* fx, double* fy, float* other) const {
    const auto miss = [&](float radiance) {
      *other = radiance;
      return false;
    };
    double t;
    if (k == 0) {
      if (!(d.z() < 0)) return miss(room);
      t = -o.z() / d.z();  // the plane z = 0
    } else {
      // k |p_xz|^2 - 2 p_z = 0 with p = o + t d: a t^2 + b t + c = 0; the viewer sees the larger root (the
      // cancellation-free form as in IntersectSurface).
      const double a = k * (d.x() * d.x() + d.z() * d.z());
      const double b = 2 * (k * (o.x() * d.x() + o.z() * d.z()) - d.z());
      const double disc = b * b - 4 * a * c_term;
      if (!(disc >= 0) || a == 0) return miss(room);
      const double sq = std::sqrt(disc);
      if (b >= 0) {
        const double q = -0.5 * (b + sq);
        if (q == 0) return miss(room);
        t = c_term / q;
      } else {
        t = -0.5 * (b - sq) / a;
      }
    }
    if (!(t > 0)) return miss(room);
    const double py = o.y() + t * d.y();
    double v = py * v_from_y;
    if (std::abs(v) > bezel_v && bump_support.empty()) return miss(room);
    const double px = o.x() + t * d.x();
    double u, sin_phi = 0, cos_phi = 1;
    if (k == 0) {
      u = px * u_from_s;
    } else {
      const double pz = o.z() + t * d.z();
      sin_phi = k * px;
      cos_phi = 1 - k * pz;
      const double den = 2 - k * pz;  // 1 + cos(phi)
      const double tan_half = k * px / den;
      const double phi = (den > 0 && std::abs(tan_half) <= 1) ? 2 * FastAtan(tan_half) : std::atan2(k * px, 1 - k * pz);
      u = phi * u_from_phi;
    }
    if (!bump_support.empty()) {
      for (const Box& box : bump_support) {
        if (u >= box.u0 && u <= box.u1 && v >= box.v0 && v <= box.v1) {
          ++*refined;
          Refine(d, sin_phi, cos_phi, &u, &v);
          break;
        }
      }
    }
    *fx = (u + 1) * px_per_u;
    *fy = (v + 1) * py_per_v;
    if (!(*fx >= 0 && *fy >= 0 && *fx < display.width && *fy < display.height)) {
      return miss((std::abs(u) <= bezel_u && std::abs(v) <= bezel_v) ? bezel : room);
    }
    return true;
  }

  // Moves (u, v) from the base surface onto the deviated one, P(u, v) + dev(u, v) n(u, v) = o + t d, in the
  // true centre frame by fixed-point steps: intersect the ray with the tangent plane at the current deviated
  // point, take off the deviation along the normal and project back onto the base surface (TrueGeometry's
  // BasePoint and Normal, written out with one sincos per step; (u, v) of a point from its upright image). Each step shrinks the error by about
  // |grad dev| tan(incidence) (0.01 for the 2 mm bulge scene, below 0.1 for any bump less steep than 1:10 seen
  // at less than 45 deg), so stopping after a step below 1e-5 in u, v leaves below 1e-6 (0.6 um on a 1.2 m
  // panel, 0.003 display px); at most 8 steps.
  // sin_phi, cos_phi: of the base hit's angle (exact there: k x and 1 - k z on the cylinder); each step gets
  // them from its own point the same way, so no step calls sin or cos.
  void Refine(const Eigen::Vector3d& d_upright, double sin_phi, double cos_phi, double* u, double* v) const {
    const Eigen::Vector3d origin = geometry.shear * o, d = geometry.shear * d_upright;
    const double cl = geometry.cos_l, sl = geometry.sin_l, tan_l = sl / cl;
    double uu = *u, vv = *v, sn = sin_phi, cs = cos_phi;
    for (int iter = 0; iter < 8; ++iter) {
      const double arc = uu * geometry.half_w, w = -vv * geometry.half_h;
      const double x = k == 0 ? arc : sn / k, z = k == 0 ? 0.0 : (1 - cs) / k;
      const Eigen::Vector3d base(x, w * cl, z + w * sl);
      const Eigen::Vector3d n = Eigen::Vector3d(-sn * cl, -cs * sl, cs * cl) / std::sqrt(sn * sn * cl * cl + cs * cs);
      const double dev = geometry.truth->DeviationMm({uu, vv});
      const double nd = n.dot(d);
      if (nd == 0) break;
      const double t = (n.dot(base - origin) + dev) / nd;
      const Eigen::Vector3d p = origin + t * d - dev * n;
      const double px = p.x(), py = p.y() / cl, pz = p.z() - p.y() * tan_l;  // upright
      double next_u = px * u_from_s;
      if (k != 0) {
        // atan2(a, b) = 2 atan(a / (hypot(a, b) + b)) for b > 0 (|angle| < 90 deg), else the library's.
        const double a = k * px, b = 1 - k * pz, r = std::sqrt(a * a + b * b);
        next_u = (b > 0 ? 2 * FastAtan(a / (r + b)) : std::atan2(a, b)) * u_from_phi;
        sn = a / r;
        cs = b / r;
      }
      const double next_v = py * v_from_y;
      const bool done = std::max(std::abs(next_u - uu), std::abs(next_v - vv)) < 1e-5;
      uu = next_u;
      vv = next_v;
      if (done) break;
    }
    *u = uu;
    *v = vv;
  }

  // The display's light at display pixel coordinates (fx, fy), on the display, averaged over the box of wx x wy
  // display px centred there: the footprint of one sample. A camera pixel integrates the light over its area; the
  // emitters (fill factor, RGB stripes: a third of a pixel each) are far finer than a sample at ordinary
  // distances (0.78 camera px per display px for the default scene), so point samples alias them into a
  // random texture that no real photo shows. The box average is exact for the separable emitter layout (stripes
  // across, fill factor down), and equals the point sample as the box shrinks.
  //
  // When the optics blur the display's pixel structure away (psf_x, psf_y: the PSF's sigma in display px along
  // each axis), the emitters are shaded by their mean over a pixel instead: a Gaussian of sigma s passes the
  // pixel grid's fundamental (1 cycle per display px) at exp(-2 pi^2 s^2), under 1e-3 for s > 0.6 display px,
  // so no real photo shows the structure there. Resolving it anyway would alias it, since the simulated blur
  // acts after sampling and a real lens acts before.
  float ShadeArea(double fx, double fy, double wx, double wy, double psf_x, double psf_y) const {
    const double x0 = fx - 0.5 * wx, x1 = fx + 0.5 * wx, y0 = fy - 0.5 * wy, y1 = fy + 0.5 * wy;
    // Tiny boxes, boxes that reach past the display's edge and huge ones (far away: many display pixels per
    // sample, where the image content aliases anyway) are point-sampled.
    if (!(wx > 1e-3 && wy > 1e-3) || wx > 16 || wy > 16 || x0 < 0 || y0 < 0 || x1 >= display.width ||
        y1 >= display.height) {
      return ShadePoint(fx, fy);
    }
    const auto overlap = [](double a0, double a1, double b0, double b1) {
      return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
    };
    const int i0 = static_cast<int>(x0), i1 = static_cast<int>(x1);
    const int j0 = static_cast<int>(y0), j1 = static_cast<int>(y1);
    double light = 0, lit_area = 0;
    if (psf_x > kStructureBlurredPx && psf_y > kStructureBlurredPx) {
      // Each pixel's mean light (pixel_mean_light), weighted by its share of the box.
      for (int j = j0; j <= j1; ++j) {
        const double oy = overlap(y0, y1, j, j + 1);
        const float* row = pixel_mean_light.data() + static_cast<size_t>(j) * display.width;
        for (int i = i0; i <= i1; ++i) light += overlap(x0, x1, i, i + 1) * oy * row[i];
      }
      return static_cast<float>(light / ((x1 - x0) * (y1 - y0)));
    }
    for (int j = j0; j <= j1; ++j) {
      const double oy = overlap(y0, y1, j + 0.5 - half_fill, j + 0.5 + half_fill);
      if (oy <= 0) continue;
      const size_t row = static_cast<size_t>(j) * display.width;
      for (int i = i0; i <= i1; ++i) {
        const size_t at = (row + static_cast<size_t>(i)) * channels;
        if (!stripes) {
          const double ox = overlap(x0, x1, i + 0.5 - half_fill, i + 0.5 + half_fill);
          if (ox <= 0) continue;
          light += ox * oy * GrayLight(at);
          lit_area += ox * oy;
          continue;
        }
        for (int stripe = 0; stripe < 3; ++stripe) {
          const double ox = overlap(x0, x1, i + (stripe + 0.5 - half_fill) / 3, i + (stripe + 0.5 + half_fill) / 3);
          if (ox <= 0) continue;
          const int channel = channels >= 3 ? 2 - stripe : 0;
          light += ox * oy * stripe_light[stripe][display.pixels[at + static_cast<size_t>(channel)]];
          lit_area += ox * oy;
        }
      }
    }
    const double area = (x1 - x0) * (y1 - y0);
    return static_cast<float>((light + black * (area - lit_area)) / area);
  }

  static constexpr double kStructureBlurredPx = 0.6;
  double psf_sigma_px = 0;  // the optics' blur as a Gaussian sigma, camera px (a disc of radius r: r / 2)

  // The light at the point (fx, fy) of the display.
  float ShadePoint(double fx_full, double fy_full) const {
    // Truncation is the floor for the non-negative values that reach it (std::floor is a call without SSE4.1).
    const int i = static_cast<int>(fx_full), j = static_cast<int>(fy_full);
    const double fx = fx_full - i, fy = fy_full - j;
    if (std::abs(fy - 0.5) > half_fill) return black;
    const size_t at = (static_cast<size_t>(j) * display.width + static_cast<size_t>(i)) * channels;
    if (!stripes) {
      if (std::abs(fx - 0.5) > half_fill) return black;
      return GrayLight(at);
    }
    // Stripes R, G, B left to right; a monochrome sensor weights them by luma, scaled so white stays 1.
    const int stripe = std::min(2, static_cast<int>(fx * 3));
    const double local = fx * 3 - stripe;
    if (std::abs(local - 0.5) > half_fill) return black;
    // Image8 colour is BGR(A): R is channel 2.
    const int channel = channels >= 3 ? 2 - stripe : 0;
    return stripe_light[stripe][display.pixels[at + static_cast<size_t>(channel)]];
  }

  // Linear light of the (whole, unstriped) pixel at byte offset `at`: the mean of its colour channels.
  float GrayLight(size_t at) const {
    if (channels == 1) return gray_light[display.pixels[at]];
    const int n = std::min(channels, 3);
    float sum = 0;
    for (int c = 0; c < n; ++c) sum += gray_light[display.pixels[at + static_cast<size_t>(c)]];
    return sum / static_cast<float>(n);
  }
};

}  // namespace

std::shared_ptr<const RayGrid> SharedRayGrid(const CameraModel& camera, double spacing_px) {
  const RayGrid* cached = nullptr;
  return SharedRayGrid(camera, spacing_px, &cached);
}

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
  photo.timing.threads = ThreadCount();
  auto t0 = Clock::now();
  double c0 = CpuMs();
  const RayGrid* cached = nullptr;
  const std::shared_ptr<const RayGrid> grid = SharedRayGrid(s.camera, ray_grid_px, &cached);
  const RayGrid& rays = *grid;
  photo.timing.rays_cached = cached != nullptr;
  photo.timing.rays_ms = MsSince(t0);
  photo.timing.rays_cpu_ms = CpuMs() - c0;

  t0 = Clock::now();
  c0 = CpuMs();
  const Tracer tracer(s, display);
  const int n = s.optics.supersample;
  const int samples_x = photo.width * n;
  // The dense-table column and fraction of every sample's x, the same for all rows.
  std::vector<int> column(static_cast<size_t>(samples_x));
  std::vector<double> fraction(static_cast<size_t>(samples_x));
  for (int x = 0; x < photo.width; ++x) {
    for (int a = 0; a < n; ++a) {
      const size_t at = static_cast<size_t>(x) * n + static_cast<size_t>(a);
      rays.DenseColumn(x + (a + 0.5) / n - 0.5, &column[at], &fraction[at]);
    }
  }
  cv::Mat radiance(photo.height, photo.width, CV_32F);
  std::atomic<int64_t> refined_total{0};
  ParallelRows(photo.height, [&](int y) {
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
        row_dirs[i] = tracer.upright_from_cam * Eigen::Vector3d(nodes[i].x(), nodes[i].y(), 1.0);
      }
      const size_t base = static_cast<size_t>(b) * samples_x;
      for (int sx = 0; sx < samples_x; ++sx) {
        const size_t i = static_cast<size_t>(column[static_cast<size_t>(sx)]);
        const double f = fraction[static_cast<size_t>(sx)];
        double fx = 0, fy = 0;
        float other = 0;
        if (tracer.Hit((1 - f) * row_dirs[i] + f * row_dirs[i + 1], b < n ? &refined : &unused_refined, &fx, &fy,
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
    std::fill(row, row + photo.width, 0.0f);
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
          const double psf_x = tracer.psf_sigma_px * n * wx, psf_y = tracer.psf_sigma_px * n * wy;
          value = std::isnan(wx) || std::isnan(wy) ? tracer.ShadePoint(fx, fys[at])
                                                   : tracer.ShadeArea(fx, fys[at], wx, wy, psf_x, psf_y);
        }
        row[sx / n] += value;
      }
    }
    const float scale = 1.0f / static_cast<float>(n * n);
    for (int x = 0; x < photo.width; ++x) row[x] *= scale;
    refined_total += refined;
  });
  photo.timing.rays = static_cast<int64_t>(photo.width) * photo.height * n * n;
  photo.timing.refined_rays = refined_total;
  photo.timing.trace_ms = MsSince(t0);
  photo.timing.trace_cpu_ms = CpuMs() - c0;

  t0 = Clock::now();
  c0 = CpuMs();
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
  photo.timing.optics_cpu_ms = CpuMs() - c0;

  t0 = Clock::now();
  c0 = CpuMs();
  const double cx = 0.5 * (photo.width - 1), cy = 0.5 * (photo.height - 1), r2_corner = cx * cx + cy * cy;
  const double max_code = s.sensor.bits == 16 ? 65535.0 : 255.0;
  const double full_well = s.sensor.full_well_e, read2 = s.sensor.read_noise_e * s.sensor.read_noise_e;
  photo.pixels.resize(static_cast<size_t>(photo.width) * photo.height);
  ParallelRows(photo.height, [&](int y) {
    // One stream per row, seeded from (seed, row), so the noise does not depend on the thread count.
    // The start is hashed: consecutive multiples of the increment would make each row the previous row's
    // stream shifted by one number.
    SplitMix64 rng{Mix64(s.sensor.seed ^ Mix64(static_cast<uint64_t>(y) + 0x632BE59BD9B4E019ull))};
    const float* row = radiance.ptr<float>(y);
    const double gain_y = s.optics.exposure, dy2 = (y - cy) * (y - cy);
    uint16_t* out = &photo.pixels[static_cast<size_t>(y) * photo.width];
    for (int x = 0; x < photo.width; ++x) {
      const double r2 = ((x - cx) * (x - cx) + dy2) / r2_corner;
      double v = row[x] * gain_y * (1 - s.optics.vignetting * r2);
      if (s.sensor.noise) {
        // Poisson-Gaussian: shot noise of the collected electrons plus Gaussian read noise. Above 20 e the shot
        // noise is Gaussian, and the sum of the two Gaussians is one Gaussian of variance e + read^2; below,
        // Poisson plus read noise.
        const double electrons = std::max(0.0, v * full_well);
        const double e = electrons > 20 ? electrons + std::sqrt(electrons + read2) * rng.Normal()
                                        : rng.Poisson(electrons) + s.sensor.read_noise_e * rng.Normal();
        v = e / full_well;
      }
      v = std::clamp(v, 0.0, 1.0);
      if (s.sensor.gamma != 1) v = std::pow(v, 1 / s.sensor.gamma);
      out[x] = static_cast<uint16_t>(v * max_code + 0.5);
    }
  });
  photo.timing.sensor_ms = MsSince(t0);
  photo.timing.sensor_cpu_ms = CpuMs() - c0;
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
                       {"lean_definition", kLeanDefinition},
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

cv::Mat PhotoToMat(const SyntheticPhoto& photo) {
  cv::Mat image(photo.height, photo.width, photo.bits == 8 ? CV_8U : CV_16U);
  for (size_t i = 0; i < photo.pixels.size(); ++i) {
    if (photo.bits == 8) {
      image.data[i] = static_cast<uint8_t>(photo.pixels[i]);
    } else {
      image.ptr<uint16_t>(0)[i] = photo.pixels[i];
    }
  }
  return image;
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
