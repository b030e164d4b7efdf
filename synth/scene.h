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
#include "core/look_at.h"  // ScreenFromCamLookAt, which scenes are placed with
#include "core/pose.h"
#include "core/monitor.h"
#include "synth/true_monitor.h"

namespace curvecheck {

class ConfigMap;

// Scene key display.layout: rgb | bgr | none sets rgb_stripes and stripes_bgr (none = the whole pixel emits its
// colour); the older key rgb_stripes: true | false is still read.
struct DisplayModel {
  double fill_factor = 0.85;  // emitting fraction of a pixel along each axis (or of each stripe)
  bool rgb_stripes = true;    // three vertical sub-pixels, R, G, B left to right
  bool stripes_bgr = false;   // the stripes in the order B, G, R (some panels)
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

// How a ray's sample of the display is shaded (scene key optics.sampling: footprint | point; parsed and printed
// only by the scene reader and SamplingName). kFootprint: the display's light averaged over the sample's footprint
// (DisplayLight::ShadeAreaN), as a camera pixel integrates it. kPoint: the light at the ray's hit alone, as a
// ray tracer with a few rays per pixel and no footprint does; the emitters (fill factor, stripes), finer than a
// sample, alias into a texture (moire, random-looking where the display pitch is below a camera px) that a
// real lens would blur away: a stress condition for detection and for the intervals, not a real camera.
enum class Sampling { kFootprint, kPoint };
const char* SamplingName(Sampling sampling);  // "footprint", "point"

struct Optics {
  int supersample = 2;         // rays per pixel along each axis
  Sampling sampling = Sampling::kFootprint;
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

// The imaging chain (scene key imaging.preset). kClean: the monochrome chain of Optics and Sensor (linear light,
// Gaussian or disc blur, quadratic vignetting, Poisson-Gaussian noise, 8 or 16 bit gray): the unit tests' mode.
// The others are the realistic colour chain of Imaging with the numbers of a camera class
// (shared/design/cameras.md; [E] values there are estimates, exposed as defaults).
enum class ImagingPreset { kClean, kPhone, kIlc24, kWebcam };
const char* ImagingPresetName(ImagingPreset preset);  // "clean", "phone", "ilc24", "webcam"

enum class ColourFilter { kRggb, kNone };               // imaging.cfa: rggb | none (a value of R, G, B per px)
enum class Demosaic { kBilinear, kVng, kEdgeAware };    // imaging.demosaic: bilinear | vng | ea (OpenCV's)
enum class ToneCurve { kSrgb, kLinear };                // imaging.tone: srgb | linear
enum class PanelAngular { kNone, kIps, kVa, kOled };    // imaging.panel: none | ips | va | oled
enum class VignettingModel { kCos4, kQuadratic };       // imaging.vignetting_model: cos4 | quadratic

// The realistic colour chain (synth/imaging.h has the formulas): trace R, G, B (the display's stripes through
// the camera's colour filters, ideal and white-balanced), the panel's luminance against viewing angle, a
// reflection on the screen, veiling glare, the optics' Gaussian combined with depth-dependent defocus,
// vignetting, exposure, electrons per raw site (PRNU, shot, read noise, full-well clipping), gain and raw
// quantization, demosaicing, tone curve, 8-bit colour, JPEG. Shared with the clean chain: optics.supersample,
// sensor.seed and sensor.noise; the clean chain's optics.blur/blur_px/vignetting/exposure and sensor.gamma/
// full_well_e/read_noise_e/bits do not act here (the output is 8-bit colour).
struct Imaging {
  ImagingPreset preset = ImagingPreset::kClean;
  ColourFilter cfa = ColourFilter::kRggb;
  Demosaic demosaic = Demosaic::kEdgeAware;
  double full_well_e = 45000;  // electrons at saturation per raw site
  double read_noise_e = 4.5;   // electrons RMS per raw site
  double prnu = 0.007;         // photo-response non-uniformity: relative gain sigma, fixed per sensor.seed
  int raw_bits = 14;           // ADC depth, 8..16; full well = 2^bits - 1 DN (VNG demosaics an 8-bit copy)
  ToneCurve tone = ToneCurve::kSrgb;
  int jpeg_quality = 92;       // 1..100, 0 = no JPEG (OpenCV/libjpeg: 4:2:0 chroma subsampling)
  double blur_px = 0.65;       // Gaussian sigma of the optics in focus (diffraction + lens + AA filter), camera px
  double f_number = 5.6;       // 0 = no defocus (pinhole)
  double focus_mm = 0;         // focus distance along the optical axis, mm; 0 = auto (the depth at the image centre)
  double pixel_pitch_um = 3.92;  // sensor pixel pitch: focal length mm = fx * pitch (defocus)
  PanelAngular panel = PanelAngular::kIps;
  double glare = 0.005;        // veiling glare: this fraction of the image's mean radiance added everywhere
  struct Reflection {
    double u = 0, v = 0;       // centre on the screen, surface coordinates (-1..1)
    double sigma_mm = 100;     // Gaussian radius along the surface, mm
    double strength = 0;       // peak radiance added, relative to a full white display pixel; 0 = none
  } reflection;
  double vignetting_ev = 0.3;  // light loss at the image corner, EV (stops)
  VignettingModel vignetting_model = VignettingModel::kCos4;
  double exposure = 0.9;       // white display -> this fraction of the full well (above 1: whites clip)
  // The true lens's departure from its camera model (synth/lens_misfit.h): the part of a real lens's distortion
  // that a calibrated model does not follow. A smooth random field of RMS lens_misfit_px per coordinate (camera
  // px at lens_misfit_reference_width; it scales with the imager, as ScaledCamera does), correlation length
  // lens_misfit_length (fraction of the image width), fixed per lens_seed (the lens, not the photo).
  double lens_misfit_px = 0;    // ilc24 0.1, phone 0.15, webcam 0.2 (estimates, [E])
  double lens_misfit_length = 0.2;
  uint64_t lens_seed = 1;
  int lens_misfit_reference_width = 0;  // camera px width the RMS is stated at; 0 = the scene camera's (set by the reader)
};

// The preset's numbers (cameras.md): phone (f/1.8, 12k e, 1 e, 10 bit, q95, blur 0.55 px), ilc24 (f/5.6, 45k e,
// 4.5 e, 14 bit, q92, blur 0.65 px), webcam (f/2.4, 8k e, 6 e, 8 bit, q85, blur 0.8 px, bilinear); clean:
// the struct's defaults with preset kClean (no lens misfit). Lens misfit RMS: ilc24 0.1 px at 6000 px width,
// phone 0.15 px, webcam 0.2 px: estimates [E] below the end-to-end 0.3-0.8 px that real calibrations report once
// the lens model enters (cameras.md), with a normal rather than a fisheye lens.
Imaging ImagingFromPreset(ImagingPreset preset);

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
  Imaging imaging;  // preset kClean: the monochrome chain of optics and sensor
};

// Reads a scene (format curvecheck.scene/1); relative paths (the camera model) are relative to the scene file.
//   monitor: PRESET | FILE                      nominal monitor
//   camera: { model: FILE.cameramodel, position_mm: [x,y,z], look_at_mm: [x,y,z], up: [x,y,z] }
//   true_monitor: { radius_mm: R | flat, translation_mm, rotation_deg, lean_deg, pitch_scale, bumps: [{u, v,
//                   sigma_u, sigma_v, height_mm}] }      all optional; default: the nominal monitor
//   display / optics / sensor: the fields of DisplayModel / Optics / Sensor, all optional
//   imaging: { preset: clean | phone | ilc24 | webcam, then any field of Imaging to override the preset's:
//              cfa, demosaic, full_well_e, read_noise_e, prnu, raw_bits, tone, jpeg_quality, blur_px, f_number,
//              focus_mm, pixel_pitch_um, panel, glare, reflection: {u, v, sigma_mm, strength}, vignetting_ev,
//              vignetting_model, exposure, lens_misfit_px, lens_misfit_length, lens_seed }
//                                              optional; default clean (a key without a preset: ilc24's)
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
// quick previews and tests. Throws Error for models without the fx, fy, cx, cy core (CAHVOR, CAHVORE), and
// for a scale that leaves fewer than kMinScaledImagerPx on the imager's short side (naming --scale).
CameraModel ScaledCamera(const CameraModel& camera, double scale);
// The smallest short side of a scaled imager, px: a 9-square board across it leaves 7 px per square, about the
// least a corner detector works with.
inline constexpr int kMinScaledImagerPx = 64;

}  // namespace curvecheck
