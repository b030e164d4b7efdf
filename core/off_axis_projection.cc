#include "core/off_axis_projection.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>

#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck {

Eigen::Vector3d OffAxisFrustum::NdcFromPoint(const Eigen::Vector3d& point_in_screen) const {
  const Eigen::Vector4d clip = clip_from_screen * point_in_screen.homogeneous();
  return clip.head<3>() / clip.w();
}

OffAxisFrustum MakeOffAxisFrustum(const Monitor& m, const Eigen::Vector3d& viewpoint, double depth_mm) {
  CheckViewpoint(m, viewpoint, "viewpoint");
  if (!(depth_mm > 0) || !std::isfinite(depth_mm)) {
    throw Error("frustum depth", fmt::format("{} mm is not a positive depth", depth_mm), "give a positive depth");
  }
  // Chord plane at z = -d_n in the screen frame; relative to the screen centre it stands sagitta mm in front
  // of it. n = O_z + d_n (Eq 4.5) = (O_z - z_centre) - sagitta, written without the large R terms.
  const Eigen::Vector3d o_rel = viewpoint - ScreenCentreInScreen(m);
  const double n = o_rel.z() - m.sagitta_mm();
  if (!(n > 0)) {
    throw Error("viewpoint",
                fmt::format("viewpoint ({:g}, {:g}, {:g}) mm is {:.1f} mm in front of the screen centre, not in front "
                            "of the plane of the screen's corners ({:.1f} mm): a linear projection cannot cover a "
                            "field of view of 180 deg or more",
                            viewpoint.x(), viewpoint.y(), viewpoint.z(), o_rel.z(), m.sagitta_mm()),
                "move the viewpoint back, or use the exact method");
  }
  OffAxisFrustum fr;
  fr.viewpoint_in_screen = viewpoint;
  const double half_wn = 0.5 * m.chord_width_mm(), half_h = 0.5 * m.height_mm;
  fr.left_mm = -half_wn - viewpoint.x();
  fr.right_mm = half_wn - viewpoint.x();
  fr.bottom_mm = -half_h - viewpoint.y();
  fr.top_mm = half_h - viewpoint.y();
  // 4.2.2: rays to the top and bottom of the centre column (the deepest points) meet the near plane at
  // (y_edge - O_y) n / (O_z - z_centre); the extents are the union with Eq 4.5.
  const double scale = n / o_rel.z();
  const double b_centre = (-half_h - viewpoint.y()) * scale, t_centre = (half_h - viewpoint.y()) * scale;
  if (b_centre < fr.bottom_mm || t_centre > fr.top_mm) fr.vertical_extents_widened = true;
  fr.bottom_mm = std::min(fr.bottom_mm, b_centre);
  fr.top_mm = std::max(fr.top_mm, t_centre);
  fr.near_mm = n;
  fr.far_mm = n + depth_mm;

  const double l = fr.left_mm, r = fr.right_mm, b = fr.bottom_mm, t = fr.top_mm, f = fr.far_mm;
  Eigen::Matrix4d proj;  // thesis Eq 4.6, left factor
  proj << 2 * n / (r - l), 0, (r + l) / (r - l), 0,  //
      0, 2 * n / (t - b), (t + b) / (t - b), 0,       //
      0, 0, -f / (f - n), -(f * n) / (f - n),         //
      0, 0, -1, 0;
  // Right factor: translation by -O. The chord plane sits at z = -d_n in the screen frame, so the eye space
  // z of a point is p_z - O_z; for a flat monitor (no axis) the same holds with the screen at z = 0.
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();
  view.block<3, 1>(0, 3) = -viewpoint;
  fr.clip_from_screen = proj * view;
  return fr;
}

}  // namespace curvecheck
