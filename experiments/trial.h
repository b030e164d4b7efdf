// One synthetic trial (architecture.md, experiments): render a pattern for a stated viewpoint -> photograph
// the true monitor showing it with the synthetic camera -> analyse the photo from pixels. `curvecheck demo`,
// `bench analyze` and `sweep` run it; `bench detect` and `bench capture` use its first stage. The two stages
// are separate because callers repeat the second over one display image (noise seeds, a render cache).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/pipeline.h"
#include "core/image_io.h"
#include "pattern/pattern.h"
#include "render/renderer.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {

// What the monitor shows: a pattern rendered for a viewpoint by a correction method.
struct TrialDisplay {
  Monitor monitor;  // nominal
  Pattern pattern;
  Eigen::Vector3d viewpoint_in_screen = Eigen::Vector3d::Zero();  // the pattern is correct for this point
  RenderOptions render;                                           // the method that drew it
  Image8 image;                                                   // gray, the monitor's resolution
  RenderTiming timing;                                            // the renderer's own times
  double wall_ms = 0;  // Render's wall time (device set-up included when this was the renderer's first frame)

  // pattern.json of this display (pattern/pattern_json.h): what the analysis reads.
  nlohmann::json PatternJson() const;
};

// Builds `spec` on the plane tangent at the screen centre for `viewpoint_in_screen` and renders it on the
// nominal `monitor`. Throws what BuildPattern and the renderer throw (a pattern that does not fit, a method
// that refuses the view, Vulkan errors).
TrialDisplay RenderTrialDisplay(Renderer& renderer, const Monitor& monitor,
                                const Eigen::Vector3d& viewpoint_in_screen, const PatternSpec& spec,
                                const RenderOptions& options = {});

struct TrialAnalysis {
  SyntheticPhoto photo;
  double photo_ms = 0;      // wall time of the synthetic photo
  AnalysisResult analysis;  // one photo: analysis.photos.front()
};

// Photographs `display` (TrialDisplay::image) with the scene's synthetic camera and analyses the photo in
// memory against `input.pattern`, the display's pattern.json on disk (the analysis reads it). `input.photo`
// and `camera_path` only name the photo and the camera (scene.camera) in the result. Throws what the
// synthetic camera and Analyze throw for bad input; a photo without the pattern is a result
// (analysis.photos.front().used false).
TrialAnalysis PhotographAndAnalyse(const SyntheticScene& scene, const Image8& display,
                                   const PhotoInput& input, const std::filesystem::path& camera_path,
                                   const AnalyzeOptions& options);

// The fit's `cylinder` candidate; null when there is no fit or the cylinder was not among its models.
const ModelFit* CylinderCandidate(const AnalysisResult& result);

}  // namespace curvecheck::experiments
