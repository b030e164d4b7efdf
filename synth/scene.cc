#include "synth/scene.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>

#include "core/config.h"
#include "core/look_at.h"  // defines ScreenFromCamLookAt, declared in scene.h too
#include "core/error.h"
#include "core/path_check.h"
#include "core/screen_geometry.h"
#include "datasets/monitor_presets.h"

namespace curvecheck {
namespace {

Eigen::Vector3d Vec3(const ConfigMap& c, const std::string& key) {
  const std::vector<double> v = c.Numbers(key, 3);
  return {v[0], v[1], v[2]};
}

// true_monitor: starts from the nominal curvature already in `truth`.
void ReadTrueMonitor(const ConfigMap& t, const Monitor& nominal, TrueMonitor* truth) {
  t.RejectUnknownKeys({"radius_mm", "translation_mm", "rotation_deg", "lean_deg", "pitch_scale", "bumps"});
  if (t.Has("radius_mm")) {
    truth->curvature_per_mm = t.IsWord("radius_mm", "flat") ? 0.0 : 1.0 / t.PositiveNumber("radius_mm");
  }
  if (t.Has("translation_mm")) truth->translation_mm = Vec3(t, "translation_mm");
  if (t.Has("rotation_deg")) truth->rotation_deg = Vec3(t, "rotation_deg");
  if (t.Has("lean_deg")) {
    truth->lean_deg = t.Number("lean_deg");
    if (!(std::abs(truth->lean_deg) < 45)) t.Fail("lean_deg", "is not within +-45 deg", "give the axis tilt in degrees");
  }
  if (t.Has("pitch_scale")) {
    truth->pitch_scale = t.Number("pitch_scale");
    if (!(std::abs(truth->pitch_scale - 1) <= 0.1)) {
      t.Fail("pitch_scale", "is not within 0.9-1.1", "give the true pixel pitch over the datasheet's, e.g. 1.001");
    }
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
      truth->bumps.push_back(bump);
    }
  }
  Monitor check = nominal;
  check.curvature_per_mm = truth->curvature_per_mm;
  check.Check(t.source() + " (true_monitor)");
}

// The index of the word `key` holds among `words` (compared without case); Fail lists them otherwise.
int Choice(const ConfigMap& c, const std::string& key, std::initializer_list<const char*> words) {
  int i = 0;
  std::string all;
  for (const char* w : words) {
    if (c.IsWord(key, w)) return i;
    all += (i++ ? ", " : "") + std::string(w);
  }
  c.Fail(key, "is not one of " + all, "choose one");
}

void ReadDisplay(const ConfigMap& d, DisplayModel* display) {
  d.RejectUnknownKeys({"fill_factor", "rgb_stripes", "layout", "gamma", "black", "bezel_mm", "bezel", "room"});
  if (d.Has("fill_factor")) display->fill_factor = d.PositiveNumber("fill_factor");
  if (d.Has("rgb_stripes")) display->rgb_stripes = d.IsWord("rgb_stripes", "true");
  if (d.Has("layout")) {
    const int layout = Choice(d, "layout", {"rgb", "bgr", "none"});
    display->rgb_stripes = layout != 2;
    display->stripes_bgr = layout == 1;
  }
  if (d.Has("gamma")) display->gamma = d.PositiveNumber("gamma");
  if (d.Has("black")) display->black = d.Number("black");
  if (d.Has("bezel_mm")) display->bezel_mm = d.Number("bezel_mm");
  if (d.Has("bezel")) display->bezel = d.Number("bezel");
  if (d.Has("room")) display->room = d.Number("room");
  if (display->fill_factor > 1) d.Fail("fill_factor", "is above 1", "give the emitting fraction, 0..1");
  if (display->bezel_mm < 0) {
    d.Fail("bezel_mm", fmt::format("is {}, below zero", display->bezel_mm), "give 0 or more mm");
  }
}

}  // namespace

const char* BlurName(Blur blur) {
  switch (blur) {
    case Blur::kNone: return "none";
    case Blur::kGaussian: return "gaussian";
    case Blur::kDisc: return "disc";
  }
  return "none";
}

const char* SamplingName(Sampling sampling) { return sampling == Sampling::kPoint ? "point" : "footprint"; }

const char* ImagingPresetName(ImagingPreset preset) {
  switch (preset) {
    case ImagingPreset::kClean: return "clean";
    case ImagingPreset::kPhone: return "phone";
    case ImagingPreset::kIlc24: return "ilc24";
    case ImagingPreset::kWebcam: return "webcam";
  }
  return "clean";
}

Imaging ImagingFromPreset(ImagingPreset preset) {
  Imaging g;  // the defaults are ilc24's (but for the lens misfit, set below)
  g.preset = preset;
  switch (preset) {
    case ImagingPreset::kClean:  // the clean chain's lens is its model exactly
      break;
    case ImagingPreset::kIlc24:
      g.lens_misfit_px = 0.1;
      break;
    case ImagingPreset::kPhone:  // 4080 x 3072 binned, 2.4 um, f/1.8; vignetting after the ISP's shading
      g.full_well_e = 12000;
      g.read_noise_e = 1;
      g.raw_bits = 10;
      g.jpeg_quality = 95;
      g.blur_px = 0.55;
      g.f_number = 1.8;
      g.pixel_pitch_um = 2.4;
      g.vignetting_ev = 0.5;
      g.lens_misfit_px = 0.15;
      break;
    case ImagingPreset::kWebcam:  // C920 class: 1080p MJPEG, bilinear demosaic, 8-bit
      g.full_well_e = 8000;
      g.read_noise_e = 6;
      g.raw_bits = 8;
      g.jpeg_quality = 85;
      g.blur_px = 0.8;
      g.f_number = 2.4;
      g.pixel_pitch_um = 2.7;
      g.demosaic = Demosaic::kBilinear;
      g.vignetting_ev = 0.7;
      g.lens_misfit_px = 0.2;
      break;
  }
  return g;
}

namespace {

void ReadOptics(const ConfigMap& o, Optics* optics) {
  o.RejectUnknownKeys({"supersample", "sampling", "blur", "blur_px", "vignetting", "exposure"});
  if (o.Has("supersample")) optics->supersample = o.PositiveInt("supersample");
  if (o.Has("sampling")) optics->sampling = static_cast<Sampling>(Choice(o, "sampling", {"footprint", "point"}));
  if (o.Has("blur")) optics->blur = static_cast<Blur>(Choice(o, "blur", {"none", "gaussian", "disc"}));
  if (o.Has("blur_px")) optics->blur_px = o.Number("blur_px");
  if (o.Has("vignetting")) optics->vignetting = o.Number("vignetting");
  if (o.Has("exposure")) optics->exposure = o.PositiveNumber("exposure");
  if (optics->supersample > 8) o.Fail("supersample", "is above 8", "use 1..8 rays per pixel per axis");
  if (optics->blur_px < 0) o.Fail("blur_px", fmt::format("is {}, below zero", optics->blur_px), "give 0 or more px");
  if (optics->vignetting < 0 || optics->vignetting > 1) {
    o.Fail("vignetting", fmt::format("is {}, outside 0..1", optics->vignetting), "give the corner light loss, 0..1");
  }
}

void ReadSensor(const ConfigMap& n, Sensor* sensor) {
  n.RejectUnknownKeys({"gamma", "full_well_e", "read_noise_e", "noise", "seed", "bits"});
  if (n.Has("gamma")) sensor->gamma = n.PositiveNumber("gamma");
  if (n.Has("full_well_e")) sensor->full_well_e = n.PositiveNumber("full_well_e");
  if (n.Has("read_noise_e")) sensor->read_noise_e = n.Number("read_noise_e");
  if (sensor->read_noise_e < 0) {
    n.Fail("read_noise_e", fmt::format("is {}, below zero", sensor->read_noise_e), "give 0 or more electrons");
  }
  if (n.Has("noise")) sensor->noise = n.IsWord("noise", "true");
  if (n.Has("seed")) {
    // A whole number that a double holds exactly; anything else (negative, fractional, 1e30) would be an
    // undefined conversion (found by fuzz_scene).
    const double seed = n.Number("seed");
    if (!(seed >= 0 && seed <= 9007199254740992.0 && seed == std::floor(seed))) {
      n.Fail("seed", fmt::format("is {}", seed), "give a whole number from 0 to 2^53");
    }
    sensor->seed = static_cast<uint64_t>(seed);
  }
  if (n.Has("bits")) sensor->bits = n.PositiveInt("bits");
  if (sensor->bits != 8 && sensor->bits != 16) n.Fail("bits", "is not 8 or 16", "choose 8 or 16");
}

void ReadImaging(const ConfigMap& m, Imaging* imaging) {
  m.RejectUnknownKeys({"preset", "cfa", "demosaic", "full_well_e", "read_noise_e", "prnu", "raw_bits", "tone",
                       "jpeg_quality", "blur_px", "f_number", "focus_mm", "pixel_pitch_um", "panel", "glare",
                       "reflection", "vignetting_ev", "vignetting_model", "exposure", "lens_misfit_px",
                       "lens_misfit_length", "lens_seed"});
  // The preset first, then the keys that override it; keys without a preset override ilc24 (the realistic
  // default).
  ImagingPreset preset = ImagingPreset::kIlc24;
  if (m.Has("preset")) preset = static_cast<ImagingPreset>(Choice(m, "preset", {"clean", "phone", "ilc24", "webcam"}));
  *imaging = ImagingFromPreset(preset);
  Imaging& g = *imaging;
  if (m.Has("cfa")) g.cfa = static_cast<ColourFilter>(Choice(m, "cfa", {"rggb", "none"}));
  if (m.Has("demosaic")) g.demosaic = static_cast<Demosaic>(Choice(m, "demosaic", {"bilinear", "vng", "ea"}));
  if (m.Has("full_well_e")) g.full_well_e = m.PositiveNumber("full_well_e");
  if (m.Has("read_noise_e")) g.read_noise_e = m.Number("read_noise_e");
  if (m.Has("prnu")) g.prnu = m.Number("prnu");
  if (m.Has("raw_bits")) g.raw_bits = m.PositiveInt("raw_bits");
  if (m.Has("tone")) g.tone = static_cast<ToneCurve>(Choice(m, "tone", {"srgb", "linear"}));
  if (m.Has("jpeg_quality") && !m.IsWord("jpeg_quality", "off")) {
    const double q = m.Number("jpeg_quality");
    if (!(q >= 0 && q <= 100 && q == std::floor(q))) {
      m.Fail("jpeg_quality", fmt::format("is {}", q), "give a whole number 1..100, or 0 / off for no JPEG");
    }
    g.jpeg_quality = static_cast<int>(q);
  } else if (m.Has("jpeg_quality")) {
    g.jpeg_quality = 0;
  }
  if (m.Has("blur_px")) g.blur_px = m.Number("blur_px");
  if (m.Has("f_number")) g.f_number = m.Number("f_number");
  if (m.Has("focus_mm")) g.focus_mm = m.IsWord("focus_mm", "auto") ? 0.0 : m.PositiveNumber("focus_mm");
  if (m.Has("pixel_pitch_um")) g.pixel_pitch_um = m.PositiveNumber("pixel_pitch_um");
  if (m.Has("panel")) g.panel = static_cast<PanelAngular>(Choice(m, "panel", {"none", "ips", "va", "oled"}));
  if (m.Has("glare")) g.glare = m.Number("glare");
  if (m.Has("reflection")) {
    const ConfigMap r = m.Map("reflection");
    r.RejectUnknownKeys({"u", "v", "sigma_mm", "strength"});
    if (r.Has("u")) g.reflection.u = r.Number("u");
    if (r.Has("v")) g.reflection.v = r.Number("v");
    if (r.Has("sigma_mm")) g.reflection.sigma_mm = r.PositiveNumber("sigma_mm");
    if (r.Has("strength")) g.reflection.strength = r.Number("strength");
    if (g.reflection.strength < 0) r.Fail("strength", "is below zero", "give 0 (none) or more, relative to white");
  }
  if (m.Has("vignetting_ev")) g.vignetting_ev = m.Number("vignetting_ev");
  if (m.Has("vignetting_model")) {
    g.vignetting_model = static_cast<VignettingModel>(Choice(m, "vignetting_model", {"cos4", "quadratic"}));
  }
  if (m.Has("exposure")) g.exposure = m.PositiveNumber("exposure");
  if (m.Has("lens_misfit_px")) g.lens_misfit_px = m.Number("lens_misfit_px");
  if (m.Has("lens_misfit_length")) g.lens_misfit_length = m.PositiveNumber("lens_misfit_length");
  if (m.Has("lens_seed")) {
    const double seed = m.Number("lens_seed");
    if (!(seed >= 0 && seed <= 9007199254740992.0 && seed == std::floor(seed))) {
      m.Fail("lens_seed", fmt::format("is {}", seed), "give a whole number from 0 to 2^53");
    }
    g.lens_seed = static_cast<uint64_t>(seed);
  }
  if (!(g.lens_misfit_px >= 0 && g.lens_misfit_px <= 10)) {
    m.Fail("lens_misfit_px", fmt::format("is {}", g.lens_misfit_px),
           "give the RMS of the true lens's departure from its model, 0..10 camera px");
  }
  if (!(g.lens_misfit_length >= 0.02 && g.lens_misfit_length <= 10)) {
    m.Fail("lens_misfit_length", fmt::format("is {}", g.lens_misfit_length),
           "give the correlation length as a fraction of the image width, 0.02..10");
  }
  if (g.read_noise_e < 0) m.Fail("read_noise_e", "is below zero", "give 0 or more electrons");
  if (!(g.prnu >= 0 && g.prnu < 0.2)) m.Fail("prnu", fmt::format("is {}", g.prnu), "give a fraction 0..0.2");
  if (g.raw_bits < 8 || g.raw_bits > 16) m.Fail("raw_bits", "is not within 8..16", "give the ADC's bits");
  if (g.blur_px < 0) m.Fail("blur_px", "is below zero", "give the optics' Gaussian sigma, 0 or more px");
  if (g.f_number < 0) m.Fail("f_number", "is below zero", "give the f-number, or 0 for no defocus");
  if (!(g.glare >= 0 && g.glare < 1)) m.Fail("glare", fmt::format("is {}", g.glare), "give a fraction 0..1");
  if (!(g.vignetting_ev >= 0 && g.vignetting_ev <= 4)) {
    m.Fail("vignetting_ev", fmt::format("is {}", g.vignetting_ev), "give the corner light loss, 0..4 EV");
  }
}

// Applies one "dotted.key=value" override to the YAML document `root` (read from `path`, named in errors).
void ApplyOverride(const std::string& o, const std::filesystem::path& path, YAML::Node* root) {
  const std::string where = "--set " + o;
  const size_t eq = o.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw Error(where, "is not KEY=VALUE", "write e.g. optics.blur=none or true_monitor.lean_deg=0.5");
  }
  std::vector<std::string> keys;
  for (size_t start = 0, dot; start <= eq; start = dot + 1) {
    dot = std::min(o.find('.', start), eq);
    keys.push_back(o.substr(start, dot - start));
    if (keys.back().empty()) throw Error(where, "has an empty key", "write e.g. optics.blur=none");
  }
  YAML::Node node;
  node.reset(*root);
  for (size_t i = 0; i + 1 < keys.size(); ++i) {
    if (node[keys[i]] && !node[keys[i]].IsMap()) {
      throw Error(where, fmt::format("'{}' is not a mapping in {}", keys[i], path.string()), "set a field inside it");
    }
    YAML::Node child = node[keys[i]];
    node.reset(child);
  }
  YAML::Node value;
  try {
    value = YAML::Load(o.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw Error(where, fmt::format("has a value that is not YAML ({})", e.msg), "quote it or fix its syntax");
  }
  // An empty value (or null, ~) loads as a null node, which the scene reader takes for an absent key: the file's
  // value, or the default, would be used in silence (issue 17: `--set optics.blur_px=` read as 0 or ignored).
  if (value.IsNull()) {
    throw Error(where, "has no value after '='",
                fmt::format("give one, e.g. {}=1.5, or leave out --set to keep the scene's value", o.substr(0, eq)));
  }
  node[keys.back()] = value;
}

// The scene reader of both SceneFromConfig overloads. `scene_dir` null: the scene is in no folder, so its monitor
// is a preset name or a path as given, and `read_camera` reads the camera model it names.
SyntheticScene ReadScene(const ConfigMap& c, const std::filesystem::path* scene_dir,
                         const std::function<CameraModel(const std::string& model)>& read_camera) {
  c.RejectUnknownKeys(
      {"format", "name", "monitor", "camera", "true_monitor", "display", "optics", "sensor", "imaging"});
  if (c.Has("format") && c.String("format") != "curvecheck.scene/1") {
    c.Fail("format", "is not 'curvecheck.scene/1'", "this version reads curvecheck.scene/1");
  }
  SyntheticScene s;
  const std::string monitor_spec = c.String("monitor");
  const std::filesystem::path monitor_path = scene_dir ? *scene_dir / monitor_spec : std::filesystem::path();
  // The non-throwing exists: a monitor value that is no path (too long, a NUL byte) is a preset name or an error
  // of LoadMonitor, not a std::filesystem exception (fuzz_scene found "File name too long" escaping).
  std::error_code ec;
  if (scene_dir && ClassifyPath(monitor_path) == PathKind::kLinkLoop) RequireFile(monitor_path);
  s.monitor =
      LoadMonitor(scene_dir && std::filesystem::exists(monitor_path, ec) ? monitor_path.string() : monitor_spec);
  s.truth.curvature_per_mm = s.monitor.curvature_per_mm;

  const ConfigMap cam = c.Map("camera");
  cam.RejectUnknownKeys({"model", "position_mm", "look_at_mm", "up"});
  s.camera_model_path = cam.String("model");
  s.camera = read_camera(s.camera_model_path);
  s.screen_from_cam.translation = Vec3(cam, "position_mm");
  const Eigen::Vector3d look_at = cam.Has("look_at_mm") ? Vec3(cam, "look_at_mm") : ScreenCentreInScreen(s.monitor);
  const Eigen::Vector3d up = cam.Has("up") ? Vec3(cam, "up") : Eigen::Vector3d::UnitY();
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, look_at, up);

  if (c.Has("true_monitor")) ReadTrueMonitor(c.Map("true_monitor"), s.monitor, &s.truth);
  if (c.Has("display")) ReadDisplay(c.Map("display"), &s.display);
  if (c.Has("optics")) ReadOptics(c.Map("optics"), &s.optics);
  if (c.Has("sensor")) ReadSensor(c.Map("sensor"), &s.sensor);
  if (c.Has("imaging")) ReadImaging(c.Map("imaging"), &s.imaging);
  s.imaging.lens_misfit_reference_width = s.camera.width;  // the misfit's RMS is stated for the scene's own camera
  CheckViewpoint(s.monitor, s.screen_from_cam.translation, c.source() + " (camera.position_mm)");
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
  for (const std::string& o : overrides) ApplyOverride(o, path, &root);
  YAML::Emitter out;
  out << root;
  std::string source = path.string() + " with";
  for (const std::string& o : overrides) source += " " + o;
  return SceneFromConfig(ConfigMap::Parse(out.c_str(), source), path.parent_path());
}

CameraModel ScaledCamera(const CameraModel& camera, double scale) {
  if (!(scale > 0 && scale <= 1)) {
    throw Error("--scale", fmt::format("{} is not in (0, 1]", scale), "give the fraction of the imager to keep, such as 0.5");
  }
  if (camera.lensmodel.rfind("LENSMODEL_CAHVOR", 0) == 0 || camera.intrinsics.size() < 4) {
    throw Error("--scale", fmt::format("the camera's lens model {} has no fx, fy, cx, cy core to scale", camera.lensmodel),
                "use the full imager with this lens model");
  }
  // A photo must keep a size a board can be measured in: --scale 0.0001 made a 1 x 1 px photo that reported
  // "60 of 60 features visible".
  const double short_side_px = std::min(camera.width, camera.height) * scale;
  if (!(short_side_px >= kMinScaledImagerPx - 0.5)) {
    throw Error("--scale",
                fmt::format("{:g} shrinks the {} x {} px imager to {} x {} px, below {} px on its short side, too "
                            "small to detect a board in",
                            scale, camera.width, camera.height, std::lround(camera.width * scale),
                            std::lround(camera.height * scale), kMinScaledImagerPx),
                fmt::format("give a scale of at least {:.3g}",
                            static_cast<double>(kMinScaledImagerPx) / std::min(camera.width, camera.height)));
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

}  // namespace curvecheck
