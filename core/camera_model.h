// Camera models: the adapter to mrcal (architecture.md: mrcal only inside calibrate/ and this adapter). Any
// mrcal lens model (LENSMODEL_PINHOLE, OPENCV4/5/8/12, SPLINED_STEREOGRAPHIC_..., ...) read from or written to a
// mrcal `.cameramodel` file, projected and unprojected through libmrcal. Camera frame: x right, y down, z
// forward; pixel coordinates with pixel centres at integers (mrcal's convention, as everywhere in curvecheck).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace curvecheck {

struct CameraModel {
  std::string lensmodel;          // mrcal's name, e.g. "LENSMODEL_OPENCV8"
  std::vector<double> intrinsics;  // fx, fy, cx, cy, then the model's distortion parameters
  int width = 0, height = 0;       // imager size, px
  // The pose stored with the model (mrcal's rt_cam_ref: Rodrigues rotation, translation); carried through
  // unchanged, not used by the projection.
  Eigen::Matrix<double, 6, 1> rt_cam_ref = Eigen::Matrix<double, 6, 1>::Zero();

  // Throws Error naming `where` unless the lens model is known to mrcal, the parameter count matches it, the
  // values are finite and the imager size is positive.
  void Check(const std::string& where) const;
};

// True if mrcal knows the lens model `name` (mrcal_lensmodel_from_name: the type and, for parametric families such
// as LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100, well-formed parameters).
bool IsMrcalLensModel(const std::string& name);
// The number of intrinsics of mrcal lens model `name` (4 core + distortions). Throws Error for an unknown model.
int LensModelParameterCount(const std::string& name);

// Reads a mrcal .cameramodel file (through libmrcal). Throws Error naming the file on any problem.
CameraModel ReadCameraModel(const std::filesystem::path& path);
// Parses the text of a .cameramodel file; `source` names it in errors.
CameraModel ParseCameraModel(const std::string& text, const std::string& source);
// Writes a .cameramodel file that mrcal's own tools read; atomically.
void WriteCameraModel(const std::filesystem::path& path, const CameraModel& model);

// Projects camera-frame points to pixel coordinates. dq_dp (optional): 2x3 gradient per point. dq_dintrinsics
// (optional): 2 x n gradient per point with respect to the intrinsics (mrcal's order, n = intrinsics.size()),
// libmrcal's exact one (dense: fine for OPENCV models, slow for splined ones).
std::vector<Eigen::Vector2d> ProjectPoints(const CameraModel& model, const std::vector<Eigen::Vector3d>& points,
                                           std::vector<Eigen::Matrix<double, 2, 3>>* dq_dp = nullptr,
                                           std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>>* dq_dintrinsics =
                                               nullptr);
Eigen::Vector2d ProjectPoint(const CameraModel& model, const Eigen::Vector3d& point);
// ProjectPoints for one point at a time in inner loops (the screen fit's cost function, called millions of times):
// the lens model is parsed once, at construction, and nothing is allocated per call. Same mrcal call, same numbers.
// `model` must outlive the projector; copies share the parsed lens model.
class PointProjector {
 public:
  explicit PointProjector(const CameraModel& model);
  // The pixel of camera-frame point p and, optionally, its 2x3 gradient. intrinsics (optional): values to project
  // with instead of the model's (same lens model, intrinsics.size() of them); dq_dintrinsics (optional): 2 x n
  // row-major, the gradient with respect to them (libmrcal's exact one, as ProjectPoints). Throws Error if mrcal fails.
  Eigen::Vector2d Project(const Eigen::Vector3d& p, Eigen::Matrix<double, 2, 3>* dq_dp = nullptr,
                          const double* intrinsics = nullptr, double* dq_dintrinsics = nullptr) const;
  const CameraModel& model() const { return *model_; }

 private:
  struct Lens;
  const CameraModel* model_;
  std::shared_ptr<const Lens> lens_;
};
// Unprojects pixel coordinates to unit direction vectors in the camera frame (mrcal's iterative solve).
std::vector<Eigen::Vector3d> UnprojectPixels(const CameraModel& model, const std::vector<Eigen::Vector2d>& pixels);

// A pinhole model of the given size, focal length (px) and principal point at the image centre.
CameraModel PinholeModel(int width, int height, double focal_px);

}  // namespace curvecheck
