#include "render/method.h"

#include <fmt/format.h>

#include "core/error.h"

namespace curvecheck {
namespace {

const char* FilterName(WarpFilter f) { return f == WarpFilter::kCubic ? "cubic" : "bilinear"; }
const char* SubdivisionName(MeshSubdivision s) {
  switch (s) {
    case MeshSubdivision::kUniform: return "uniform";
    case MeshSubdivision::kPerez: return "perez";
    case MeshSubdivision::kExtended: return "extended";
  }
  return "?";
}

void Require(bool ok, const std::string& where, const std::string& problem, const std::string& fix) {
  if (!ok) throw Error(where, problem, fix);
}

}  // namespace

const char* MethodName(Method m) {
  switch (m) {
    case Method::kExact: return "exact";
    case Method::kWarp: return "warp";
    case Method::kMesh: return "mesh";
    case Method::kStrips: return "strips";
    case Method::kNone: return "none";
  }
  return "?";
}

Method ParseMethod(const std::string& text, const std::string& where) {
  for (Method m : {Method::kExact, Method::kWarp, Method::kMesh, Method::kStrips, Method::kNone}) {
    if (text == MethodName(m)) return m;
  }
  throw Error(where, fmt::format("unknown method '{}'", text), "use exact, warp, mesh, strips or none");
}

void MethodOptions::Check(const std::string& where) const {
  Require(supersample >= 1 && supersample <= 16, where, fmt::format("supersample {} is out of range", supersample),
          "use 1..16 samples per axis");
  Require(std::isfinite(warp_scale) && warp_scale >= 0.25 && warp_scale <= 4, where,
          fmt::format("warp scale {} is out of range", warp_scale), "use 0.25..4");
  Require((warp_grid_cols == 0) == (warp_grid_rows == 0) && warp_grid_cols >= 0 && warp_grid_rows >= 0 &&
              warp_grid_cols <= 4096 && warp_grid_rows <= 4096,
          where, fmt::format("warp grid {}x{} is not valid", warp_grid_cols, warp_grid_rows),
          "give both cell counts (1..4096) or 0x0 for per-fragment warping");
  Require(std::isfinite(mesh_patch_px) && mesh_patch_px >= 8 && mesh_patch_px <= 2048, where,
          fmt::format("mesh patch {} px is out of range", mesh_patch_px), "use 8..2048 px");
  Require(mesh_level >= 1 && mesh_level <= 64, where, fmt::format("mesh level {} is out of range", mesh_level),
          "use 1..64 (the tessellator's limit)");
  Require(std::isfinite(mesh_tolerance_px) && mesh_tolerance_px > 0, where,
          fmt::format("mesh tolerance {} px is not positive", mesh_tolerance_px), "give a positive tolerance");
  Require(strips >= 1 && strips <= 4096, where, fmt::format("{} strips is out of range", strips), "use 1..4096");
}

nlohmann::json MethodOptions::ToJson() const {
  nlohmann::json j;
  j["name"] = MethodName(method);
  switch (method) {
    case Method::kExact:
      j["antialiasing"] = antialiasing == AntiAliasing::kAnalytic ? "analytic" : "supersample";
      if (antialiasing == AntiAliasing::kSupersample) j["supersample"] = supersample;
      break;
    case Method::kWarp:
      j["scale"] = warp_scale;
      j["filter"] = FilterName(warp_filter);
      j["grid"] = warp_grid_cols == 0 ? nlohmann::json("per_fragment") : nlohmann::json({warp_grid_cols, warp_grid_rows});
      break;
    case Method::kMesh:
      j["subdivision"] = SubdivisionName(mesh_subdivision);
      j["patch_px"] = mesh_patch_px;
      if (mesh_subdivision == MeshSubdivision::kUniform) {
        j["level"] = mesh_level;
      } else {
        j["tolerance_px"] = mesh_tolerance_px;
      }
      break;
    case Method::kStrips: j["strips"] = strips; break;
    case Method::kNone: break;
  }
  return j;
}

std::string MethodOptions::Label() const {
  switch (method) {
    case Method::kExact:
      return antialiasing == AntiAliasing::kAnalytic ? "exact analytic" : fmt::format("exact ss{}", supersample);
    case Method::kWarp:
      return fmt::format("warp s={:g} {} {}", warp_scale, FilterName(warp_filter),
                         warp_grid_cols == 0 ? std::string("per-fragment")
                                             : fmt::format("grid {}x{}", warp_grid_cols, warp_grid_rows));
    case Method::kMesh:
      return mesh_subdivision == MeshSubdivision::kUniform
                 ? fmt::format("mesh uniform {:g}px/{}", mesh_patch_px, mesh_level)
                 : fmt::format("mesh {} {:g}px tol {:g}", SubdivisionName(mesh_subdivision), mesh_patch_px,
                               mesh_tolerance_px);
    case Method::kStrips: return fmt::format("strips {}", strips);
    case Method::kNone: return "none";
  }
  return "?";
}

}  // namespace curvecheck
