// The correction methods (architecture.md, "Correction methods") and their parameters. CPU-side; the
// Vulkan implementation is in renderer.cc.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace curvecheck {

enum class Method {
  kExact,   // per-pixel ray cast (thesis 4.1)
  kWarp,    // linear off-axis render (thesis Eq 4.6, extents per 4.2.2) + resampling warp
  kMesh,    // pattern geometry tessellated and projected per vertex onto the cylinder (thesis Eq 4.7-4.9)
  kStrips,  // piecewise perspective: N vertical slices, one perspective projection each (Lorenz & Doellner)
  kNone,    // plain linear perspective for a flat screen: what an unaware application shows
};
enum class AntiAliasing {
  kAnalytic,     // box filter of the pixel footprint over the pattern's cells, integrated exactly
  kSupersample,  // n x n point samples per pixel, each ray cast exactly
};
enum class WarpFilter { kBilinear, kCubic /* Catmull-Rom, cf. thesis Listing 4.1 */ };
enum class MeshSubdivision {
  kUniform,   // every patch edge split into mesh_level segments
  kPerez,     // edge level from the displacement of the projected midpoint only (Perez et al., thesis 4.3.2)
  kExtended,  // thesis 4.3.2 extension: also the quarter points, so S-shaped edges are not missed
};

struct MethodOptions {
  Method method = Method::kExact;
  // exact
  AntiAliasing antialiasing = AntiAliasing::kAnalytic;
  int supersample = 4;  // samples per axis per pixel for kSupersample, 1..16
  // warp
  double warp_scale = 1.0;  // intermediate image size / display size, per axis, 0.25..4
  WarpFilter warp_filter = WarpFilter::kCubic;
  int warp_grid_cols = 0;  // distortion grid cells across; 0 = exact texture coordinates per fragment
  int warp_grid_rows = 0;  // distortion grid cells down; 0 = per fragment (both or neither are 0)
  // mesh
  MeshSubdivision mesh_subdivision = MeshSubdivision::kExtended;
  double mesh_patch_px = 256;        // base patch edge on the display at the screen centre, px (8..2048)
  int mesh_level = 16;               // kUniform: segments per patch edge, 1..64
  double mesh_tolerance_px = 0.05;   // kPerez/kExtended: target deviation of an edge's sample points, px
  // strips
  int strips = 32;  // vertical slices, 1..4096

  // Throws Error naming `where` for out-of-range values.
  void Check(const std::string& where) const;
  // The method name and the parameters that apply to it, e.g. {"name": "warp", "scale": 1.25, ...}.
  nlohmann::json ToJson() const;
  // Short label for tables and charts: "warp s=1.25 cubic grid 64x18".
  std::string Label() const;
};

const char* MethodName(Method m);
// "exact" | "warp" | "mesh" | "strips" | "none"; throws Error naming `where` otherwise.
Method ParseMethod(const std::string& text, const std::string& where);

}  // namespace curvecheck
