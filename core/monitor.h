// A monitor as the rig sees it: resolution, active area and nominal curvature (architecture.md, "Monitor").
//
// Curvature is stored as kappa = 1/R (1/mm) so that a flat monitor (kappa = 0) is the limit of the family,
// not a special case: the geometry functions are written to stay exact and free of cancellation as kappa -> 0.
#pragma once

#include <Eigen/Core>
#include <string>

namespace curvecheck {

class ConfigMap;

struct Monitor {
  std::string name;         // human-readable, e.g. "49in 32:9 5120x1440 1000R"
  int width_px = 0;         // Nx, display pixels
  int height_px = 0;        // Ny, display pixels
  double width_mm = 0;      // W, active width measured along the surface (arc length)
  double height_mm = 0;     // H, active height
  double curvature_per_mm = 0;  // kappa = 1/R; 0 for a flat monitor

  bool is_flat() const { return curvature_per_mm == 0; }
  // R in mm; +infinity for a flat monitor.
  double radius_mm() const;
  // Horizontal pixel pitch W/Nx (mm); square pixels are checked to 2% by Check().
  double pixel_pitch_mm() const { return width_mm / width_px; }
  // Half the angle of the cylinder sector, theta = W/(2R) (thesis Eq 4.3); 0 for flat.
  double half_sector_rad() const { return 0.5 * width_mm * curvature_per_mm; }
  // Straight-line width between the left and right edges, 2 R sin(theta) (thesis Eq 4.4, w_n).
  double chord_width_mm() const;
  // Depth of the curve: how far the edges stand in front of the screen centre, R (1 - cos theta).
  double sagitta_mm() const;

  // Throws Error (naming `where`) unless the values describe a physical monitor: positive finite sizes,
  // square pixels within 2%, a sector below 360 deg.
  void Check(const std::string& where) const;
};

// Builds a monitor from its resolution and diagonal (inches), with the aspect taken from the resolution
// (square pixels): H = D / sqrt(1 + A^2), W = D A / sqrt(1 + A^2) (thesis Eq 4.2). radius_mm <= 0 or
// infinity means flat.
Monitor MonitorFromDiagonal(std::string name, int width_px, int height_px, double diagonal_in, double radius_mm);

// Builds a monitor from its resolution and active area (mm; width is the arc length for curved panels).
Monitor MonitorFromActiveArea(std::string name, int width_px, int height_px, double width_mm, double height_mm,
                              double radius_mm);

// Reads a monitor spec (format curvecheck.monitor/1):
//   name: "..."                     optional
//   resolution: [Nx, Ny]
//   diagonal_in: 49                 exactly one of diagonal_in and active_area_mm: [W, H]
//   radius_mm: 1000                 or: flat
// Rejects missing keys, unknown keys, wrong types, NaN/inf, non-positive sizes, and radii outside
// (W / (2 pi), 1e7 mm] (below: a sector over 360 deg; above: write 'flat').
Monitor MonitorFromConfig(const ConfigMap& config);

// "1000 mm (1000R)" or "flat", for user-facing text.
std::string DescribeRadius(const Monitor& m);

}  // namespace curvecheck
