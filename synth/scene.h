// A synthetic scene: the nominal monitor, the true one, the camera (lens and pose), the display's physical
// pixels, the optics and the sensor; and the reader of scene files (format curvecheck.scene/1) with `--set`
// overrides. Part of the synthetic camera's public interface (synth/synthetic_camera.h includes it).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "core/camera_model.h"
#include "core/pose.h"
#include "core/monitor.h"
#include "synth/true_monitor.h"

namespace curvecheck {

class ConfigMap;

struct DisplayModel {
  double fill_factor = 0.85;  // emitting fraction of a pixel along each axis (or of each stripe)
  bool rgb_stripes = true;    // three vertical sub-pixels R, G, B
  double gamma = 2.2;         // code value -> linear light
  double black = 0.002;       // light of a black pixel, relative to white
  double bezel_mm = 8;        // frame width around the active area
  double bezel = 0.01;        // bezel radiance, relative to white
  double room = 0.03;         // everything else
};

// The optics' blur kernel (scene key optics.blur: none | gaussian | disc; parsed and printed only by the scene
// reader and BlurName).
enum class Blur { kNone, kGaussian, kDisc };
const char* BlurName(Blur blur);  // "none", "gaussian", "disc"

struct Optics {
  int supersample = 2;         // rays per pixel along each axis
  Blur blur = Blur::kNone;
  double blur_px = 0;          // Gaussian sigma or disc radius, camera px
  double vignetting = 0;       // relative fall-off at the image corner: gain 1 - v (r / r_corner)^2
  double exposure = 1.0;       // multiplies scene radiance (white display = 1 before fill factor)
};

struct Sensor {
  double gamma = 1.0;          // output encoding: 1 = linear (metrology), 2.2 = like a JPEG camera
  double full_well_e = 20000;  // electrons at saturation (shot noise)
  double read_noise_e = 3;     // electrons RMS
  bool noise = true;
  uint64_t seed = 1;
  int bits = 8;                // 8 or 16
};

struct SyntheticScene {
  Monitor monitor;  // nominal
  TrueMonitor truth;
  CameraModel camera;
  std::string camera_model_path;  // as given in the scene (provenance)
  // The camera in the screen frame: translation = the camera centre (mm), rotation = the camera axes x, y, z.
  Pose screen_from_cam;
  DisplayModel display;
  Optics optics;
  Sensor sensor;
};

// Reads a scene (format curvecheck.scene/1); relative paths (the camera model) are relative to the scene file.
//   monitor: PRESET | FILE                      nominal monitor
//   camera: { model: FILE.cameramodel, position_mm: [x,y,z], look_at_mm: [x,y,z], up: [x,y,z] }
//   true_monitor: { radius_mm: R | flat, translation_mm, rotation_deg, lean_deg, bumps: [{u, v, sigma_u,
//                   sigma_v, height_mm}] }      all optional; default: the nominal monitor
//   display / optics / sensor: the fields of DisplayModel / Optics / Sensor, all optional
SyntheticScene SceneFromConfig(const ConfigMap& config, const std::filesystem::path& scene_dir);
// As above, for a scene that is in no folder (the embedded datasets: experiments/scene_lookup.h): the monitor is a
// preset name (or a path as given), and `read_camera(model)` reads the camera model the scene names (camera.model
// as written in the scene, relative to the scene's own place).
SyntheticScene SceneFromConfig(const ConfigMap& config,
                               const std::function<CameraModel(const std::string& model)>& read_camera);
// `overrides` are "dotted.key=value" settings applied to the file's YAML before it is read (value in YAML, e.g.
// "optics.blur=none", "sensor.noise=false", "true_monitor.lean_deg=0.5"); they go through the same checks.
SyntheticScene LoadScene(const std::filesystem::path& path, const std::vector<std::string>& overrides = {});

// The same lens on an imager scaled by `scale` (0 < scale <= 1; size rounded): fx, fy scaled, the principal
// point moved so that q' + 0.5 = scale (q + 0.5), distortion unchanged (it acts on normalized coordinates). For
// quick previews and tests. Throws Error for models without the fx, fy, cx, cy core (CAHVOR, CAHVORE).
CameraModel ScaledCamera(const CameraModel& camera, double scale);

// The camera at `position` (screen frame, mm) looking at look_at: camera z toward look_at, x = z cross up,
// y = z cross x (down). Throws Error if up is parallel to the viewing direction.
Pose ScreenFromCamLookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& look_at, const Eigen::Vector3d& up);

}  // namespace curvecheck
