// The synthetic camera (architecture.md, "Synthetic camera"): a ray-traced photo of a true, imperfect monitor
// showing a display image, through any mrcal lens model, with the exact image position of every feature.
//
// Geometry. The nominal monitor and its screen frame are as in core/screen_geometry.h. The true monitor is a
// cylinder of its own curvature (same active width along the surface, same height and pixel grid), leaned (its
// columns tilted, see TrueMonitor::lean_deg), with a smooth deviation field along its normal (positive toward
// the viewer), and placed in the nominal frame by a rigid rotation and translation about the screen centre.
// Rays come from the camera's lens model (mrcal unprojection, precomputed on a grid and interpolated); they
// are intersected analytically with the true cylinder (mapped back through the lean's shear, so the cylinder
// stays upright) and refined by fixed-point steps onto the deviated surface where a bump reaches.
//
// Radiometry. The display is physical pixels: nearest pixel of the display image, emitting over a fill factor
// of each pixel, optionally as three vertical RGB stripes (a monochrome sensor weights them by Rec. 709 luma),
// display gamma, black level, a bezel and a dim room. Then supersampling, Gaussian or disc blur, vignetting,
// exposure, Poisson-Gaussian noise (seeded), sensor gamma and 8- or 16-bit quantization.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera_model.h"
#include "core/image_io.h"
#include "core/monitor.h"

namespace curvecheck {

class ConfigMap;
struct Feature;

// The true screen, in its own centre frame (origin at the screen centre, axes as the screen frame's): the point
// of display position (u, v) is
//   P(u, v) = C(u) + (-v H / 2) a + DeviationMm(u, v) n(u, v),   a = (0, cos(lambda), sin(lambda)),
// where C(u) = (sin(k s)/k, 0, (1 - cos(k s))/k) is the arc of the true curvature k in the plane y = 0 at arc
// length s = u W/2 (C(u) = (s, 0, 0) when flat), lambda = lean_deg, and n is the unit normal of the leaned
// surface C(u) + w a (dC/du x a, toward the viewer). So every column is a straight segment of the true height
// H along the tilted axis a, every row a horizontal arc of the true radius: an affine shear Shear() of the
// upright cylinder, not a rigid rotation (which a camera pose could not tell from the camera moving). The
// nominal screen frame then sees centre_nominal + translation_mm + Rotation() P(u, v).
struct TrueMonitor {
  double curvature_per_mm = 0;                           // 1/R_true; 0 = flat
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // of the true screen centre in the nominal centre frame
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();    // rigid, about x, y, z through the centre (applied z y x)
  double lean_deg = 0;  // axis tilt lambda (above); positive moves the top edge toward the viewer; |lambda| < 45
  struct Bump {
    double u = 0, v = 0;              // centre in surface coordinates (-1..1)
    double sigma_u = 0.1, sigma_v = 0.1;
    double height_mm = 0;             // peak deviation along the normal, toward the viewer
  };
  std::vector<Bump> bumps;

  // Rigid rotation taking true-centre-frame vectors to the nominal centre frame (rotation_deg only).
  Eigen::Matrix3d Rotation() const;
  // The lean as a linear map of the upright cylinder's centre frame onto the true centre frame:
  // (x, y, z) -> (x, y cos(lambda), z + y sin(lambda)).
  Eigen::Matrix3d Shear() const;
  // Deviation along the normal at (u, v), mm. The photo's ray tracer ignores each bump beyond 4 sigma (where it
  // is below exp(-8) = 3.4e-4 of its height); truth.json uses this full sum.
  double DeviationMm(const Eigen::Vector2d& uv) const;
};

// The definition of the lean, as written into truth.json.
inline constexpr const char* kLeanDefinition =
    "axis tilt: P(u,v) = C(u) + (-v H/2) (0, cos(lean), sin(lean)) in the true centre frame, C(u) the arc of the "
    "true radius in the plane y = 0; positive lean moves the top edge toward the viewer; rows stay arcs of the "
    "true radius, columns straight segments of length H; rotation_deg (rigid) and translation_mm apply after it";

struct DisplayModel {
  double fill_factor = 0.85;  // emitting fraction of a pixel along each axis (or of each stripe)
  bool rgb_stripes = true;    // three vertical sub-pixels R, G, B
  double gamma = 2.2;         // code value -> linear light
  double black = 0.002;       // light of a black pixel, relative to white
  double bezel_mm = 8;        // frame width around the active area
  double bezel = 0.01;        // bezel radiance, relative to white
  double room = 0.03;         // everything else
};

struct Optics {
  int supersample = 2;         // rays per pixel along each axis
  std::string blur = "none";   // none | gaussian | disc
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
  Eigen::Vector3d camera_position_in_screen = Eigen::Vector3d::Zero();
  Eigen::Matrix3d screen_from_cam = Eigen::Matrix3d::Identity();  // columns: camera x, y, z in the screen frame
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

// Camera rotation from a viewing direction: camera z toward look_at, x = z cross up, y = z cross x (down).
Eigen::Matrix3d ScreenFromCamLookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& look_at,
                                    const Eigen::Vector3d& up);

// Point of the true surface at (u, v), in the nominal screen frame, and its unit normal (toward the viewer).
Eigen::Vector3d TrueSurfacePointInScreen(const SyntheticScene& scene, const Eigen::Vector2d& uv,
                                         Eigen::Vector3d* normal_in_screen = nullptr);

// Per-pixel camera rays from the lens model: unprojected through mrcal on a grid of `spacing_px`, interpolated
// bicubically in normalized coordinates (x/z, y/z) onto a dense table of `dense_px` spacing, which is then read
// bilinearly (4 taps per ray instead of 16; the error of both steps is measured by MeasureErrorPx).
class RayGrid {
 public:
  RayGrid(const CameraModel& camera, double spacing_px, double dense_px = 4);
  // Ray direction (camera frame, z = 1, not unit length) through pixel coordinates q.
  Eigen::Vector3d Ray(const Eigen::Vector2d& q) const;
  // Row-coherent form of Ray(): the dense nodes' (x/z, y/z) interpolated to row y_px, one per dense column.
  // Ray(q) with q.y() = y_px is the linear interpolation of nodes[i], nodes[i + 1] at DenseColumn(q.x()).
  void RowNodes(double y_px, std::vector<Eigen::Vector2d>* nodes) const;
  // Dense column i (clamped so that i + 1 exists) and fraction f for pixel x coordinate x_px.
  void DenseColumn(double x_px, int* i, double* f) const;
  // Worst reprojection error (px) of interpolated rays over `samples` random pixels, against mrcal's projection.
  double MeasureErrorPx(const CameraModel& camera, int samples, uint64_t seed) const;

 private:
  double spacing_;
  int nx_, ny_;
  std::vector<Eigen::Vector2f> normalized_;  // (x/z, y/z) at the coarse nodes, row-major
  Eigen::Vector2d Node(int i, int j) const;
  Eigen::Vector2d Bicubic(const Eigen::Vector2d& q) const;
  double dense_spacing_;
  int dense_nx_ = 0, dense_ny_ = 0;
  std::vector<Eigen::Vector2d> dense_;  // (x/z, y/z) at (i * dense - 0.5, j * dense - 0.5)
};

// Wall-clock and process CPU time (all threads) per stage, ms. On a machine shared with other work the wall
// times grow while the CPU times do not; cpu / wall shows how many cores the stage actually had.
struct PhotoTiming {
  double rays_ms = 0, rays_cpu_ms = 0;      // ray table from the lens model (0 when it came from the cache)
  double trace_ms = 0, trace_cpu_ms = 0;    // intersection and display sampling, supersampled
  double optics_ms = 0, optics_cpu_ms = 0;  // blur
  double sensor_ms = 0, sensor_cpu_ms = 0;  // vignetting, exposure, noise, gamma, quantization
  int64_t rays = 0;
  int64_t refined_rays = 0;  // rays refined onto the deviation field (inside a bump's support)
  bool rays_cached = false;  // the ray table was built by an earlier photo through the same lens
  int threads = 1;
  double total_ms() const { return rays_ms + trace_ms + optics_ms + sensor_ms; }
  double total_cpu_ms() const { return rays_cpu_ms + trace_cpu_ms + optics_cpu_ms + sensor_cpu_ms; }
};

struct SyntheticPhoto {
  int width = 0, height = 0, bits = 8;
  std::vector<uint16_t> pixels;  // row-major code values (0..255 or 0..65535)
  PhotoTiming timing;
};

// The ray table for `camera` with grid spacing `spacing_px`, built on first use and kept for the process (the
// last 4 lenses), so that a sweep of photos through one lens pays for mrcal's unprojection once. Thread-safe.
std::shared_ptr<const RayGrid> SharedRayGrid(const CameraModel& camera, double spacing_px);

// Renders the photo of `display` (the display image: gray or colour, the monitor's resolution) as the scene's
// camera sees it. Runs on all cores; the ray table comes from SharedRayGrid. Throws Error if the display image does not match the monitor.
SyntheticPhoto RenderSyntheticPhoto(const SyntheticScene& scene, const Image8& display, double ray_grid_px = 16);

// truth.json: format curvecheck.truth/1 with the true geometry, the camera (model and pose) and, for each
// feature, its true image position (forward projection of the true surface point where the display shows it)
// and visibility (on the display, in front of the camera, facing it, inside the image).
nlohmann::json TruthJson(const SyntheticScene& scene, const std::vector<Feature>& features);

// Writes the photo as PNG (8 or 16 bit gray), atomically.
void WriteSyntheticPhoto(const std::filesystem::path& path, const SyntheticPhoto& photo);

// The photo as an OpenCV image, CV_8U or CV_16U by its bit depth (what the detectors take).
cv::Mat PhotoToMat(const SyntheticPhoto& photo);

}  // namespace curvecheck
