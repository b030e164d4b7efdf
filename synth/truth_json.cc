#include "synth/truth_json.h"

#include "core/screen_geometry.h"
#include "pattern/pattern.h"
#include "synth/lens_misfit.h"
#include "synth/true_monitor.h"

namespace curvecheck {

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
                       {"pitch_scale", t.pitch_scale},
                       {"bumps", bumps}};
  const Eigen::Vector3d& c = s.screen_from_cam.translation;
  nlohmann::json rot = nlohmann::json::array();
  const Eigen::Matrix3d screen_from_cam = s.screen_from_cam.RotationMatrix();
  for (int r = 0; r < 3; ++r) rot.push_back({screen_from_cam(r, 0), screen_from_cam(r, 1), screen_from_cam(r, 2)});
  j["camera"] = {{"model", s.camera_model_path},
                 {"lensmodel", s.camera.lensmodel},
                 {"intrinsics", s.camera.intrinsics},
                 {"imagersize", {s.camera.width, s.camera.height}},
                 {"position_mm", {c.x(), c.y(), c.z()}},
                 {"screen_from_cam", rot}};
  // The true lens: the model above plus this misfit (image_px below are the true lens's).
  const TrueImages truth(s);
  const LensMisfit& misfit = truth.misfit();
  j["camera"]["lens_misfit"] = {{"rms_px", misfit.rms_px()},
                                {"length_fraction_of_width", s.imaging.lens_misfit_length},
                                {"seed", s.imaging.lens_seed},
                                {"definition", "image_px = model projection q + delta(q), delta a smooth random field "
                                               "(synth/lens_misfit.h); absent from the camera model"}};
  nlohmann::json out = nlohmann::json::array();
  const Pose cam_from_screen = s.screen_from_cam.Inverse();
  for (const Feature& f : features) {
    nlohmann::json e = {{"id", f.id}};
    bool visible = f.visible && f.display_px.has_value();
    if (f.display_px) {
      const Eigen::Vector2d uv = UvFromDisplayPx(s.monitor, *f.display_px);
      Eigen::Vector3d normal;
      const Eigen::Vector3d p = TrueSurfacePointInScreen(s, uv, &normal);
      const Eigen::Vector3d p_cam = cam_from_screen * p;
      e["point_mm"] = {p.x(), p.y(), p.z()};
      visible = visible && p_cam.z() > 0 && normal.dot(c - p) > 0;
      if (p_cam.z() > 0) {
        const Eigen::Vector2d q = truth.ImageOf(p_cam);
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

}  // namespace curvecheck
