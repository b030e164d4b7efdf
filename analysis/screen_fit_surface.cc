// FittedSurfacePointsInCamera (screen_fit.h): a fitted candidate's surface, evaluated as the fit models it.
#include <fmt/format.h>

#include <memory>

#include "analysis/screen_fit.h"
#include "analysis/screen_model.h"
#include "core/error.h"

namespace curvecheck {

std::vector<Eigen::Vector3d> FittedSurfacePointsInCamera(const Monitor& nominal, const ModelFit& fit, int photo,
                                                         const std::vector<Eigen::Vector2d>& uv,
                                                         const FitOptions& options) {
  if (photo < 0 || photo >= static_cast<int>(fit.cameras.size())) {
    throw Error("fit", fmt::format("photo {} of a fit of {} photos", photo, fit.cameras.size()), "");
  }
  const ScreenModelKind kind = ParseScreenModel(fit.model, "fit");
  std::unique_ptr<DeviationBasis> basis;
  if (kind == ScreenModelKind::kCylinderDeviation) {
    basis = std::make_unique<DeviationBasis>(nominal, fit.deviation_basis_curvature_per_mm, options.deviation_nu,
                                             options.deviation_nv);
  }
  const int core = CoreParameterCount(kind);
  const Pose cam_from_centre = fit.cameras[static_cast<size_t>(photo)].centre_from_cam.Inverse();
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector2d& at : uv) {
    const double s = 0.5 * at.x() * nominal.width_mm, y = -0.5 * at.y() * nominal.height_mm;
    Eigen::Vector3d normal;
    Eigen::Vector3d p = CoreScreenPoint<double>(kind, fit.shape.data(), s, y, 0.5 * nominal.width_mm, &normal);
    if (basis) {
      const Eigen::VectorXd w = basis->Weights(at);
      p += w.dot(Eigen::Map<const Eigen::VectorXd>(fit.shape.data() + core, w.size())) * normal;
    }
    out.push_back(cam_from_centre * p);
  }
  return out;
}

}  // namespace curvecheck
