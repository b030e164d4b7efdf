// What another application needs to draw curvecheck's pattern in its own 3D scene with its own correction (issue 19
// part 1, `curvecheck pattern`): a textured quad and its texture.
//
// The quad is the near plane of the linear off-axis frustum from the viewpoint (core/off_axis_projection.h: the
// chord plane through the display's four corners, z = -R cos(theta) in the screen frame, with the extents of
// thesis Eq 4.5 widened per 4.2.2 so that the frustum covers the whole curved surface). The texture is the planar
// perspective image of the pattern from the viewpoint on that quad, at the display's resolution: the image a warp
// correction samples (the `warp` method's first pass at scale 1, without its guard texels). Seen from the
// viewpoint the textured quad covers exactly what the pattern plane shows through the display, so a correct
// correction of the application's scene puts every feature at pattern.json's display_px. (`render --method none`
// draws something else: the flat W x H panel in the tangent plane, the baseline of an unaware application.)
//
// The texture is drawn by the renderer's exact method (per-pixel ray cast, analytic anti-aliasing, gamma-correct)
// on the quad taken as a flat display of the texture's size: one copy of the pattern drawing.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "core/monitor.h"
#include "core/off_axis_projection.h"
#include "pattern/pattern.h"
#include "render/renderer.h"

namespace curvecheck {

struct PatternQuad {
  OffAxisFrustum frustum;
  int width_px = 0, height_px = 0;  // texture size: the display's resolution
  double width_mm = 0, height_mm = 0;
  // Outer corners of the texture (the edges of its edge texels), screen frame, mm.
  Eigen::Vector3d top_left_in_screen = Eigen::Vector3d::Zero(), top_right_in_screen = Eigen::Vector3d::Zero(),
                  bottom_right_in_screen = Eigen::Vector3d::Zero(), bottom_left_in_screen = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre_in_screen = Eigen::Vector3d::Zero();

  // Texture coordinates (texel centres at integers, row 0 at the top = the largest y) -> point on the quad,
  // screen frame.
  Eigen::Vector3d PointFromTexturePx(const Eigen::Vector2d& texture_px) const;
  // The quad as a flat display whose screen frame has its origin at centre_in_screen (texels need not be square).
  Monitor AsFlatMonitor() const;
};

// Throws Error if the viewpoint is invalid or not in front of the chord plane (MakeOffAxisFrustum).
PatternQuad MakePatternQuad(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen);

// Draws the texture: options.method is ignored (always the exact ray cast; its anti-aliasing, the gamma and the
// surround are used).
GrayImage RenderPatternTexture(Renderer& renderer, const PatternQuad& quad, const Eigen::Vector3d& viewpoint_in_screen,
                               const Pattern& pattern, const RenderOptions& options);

// plane.json, format "curvecheck.plane/1" (README "curvecheck pattern" lists the fields): the quad's corners in the
// screen frame and relative to the eye, which texture corner goes where (uv with v down and with v up), the eye,
// the frustum, the texture's size and encoding, the monitor.
nlohmann::json PlaneToJson(const PatternQuad& quad, const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                           const RenderOptions& options, const std::string& texture_file);

}  // namespace curvecheck
