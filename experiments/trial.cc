#include "experiments/trial.h"

#include "core/correction.h"
#include "core/stopwatch.h"
#include "pattern/pattern_json.h"

namespace curvecheck::experiments {

nlohmann::json TrialDisplay::PatternJson() const {
  return PatternToJson(pattern, monitor, viewpoint_in_screen, render.method.ToJson());
}

TrialDisplay RenderTrialDisplay(Renderer& renderer, const Monitor& monitor,
                                const Eigen::Vector3d& viewpoint_in_screen, const PatternSpec& spec,
                                const RenderOptions& options) {
  TrialDisplay d;
  d.monitor = monitor;
  d.viewpoint_in_screen = viewpoint_in_screen;
  d.render = options;
  d.pattern = BuildPattern(spec, monitor, viewpoint_in_screen, TangentPlaneAtCentre(monitor));
  const Stopwatch watch;
  GrayImage gray = renderer.Render(monitor, viewpoint_in_screen, d.pattern, options, &d.timing);
  d.wall_ms = watch.Ms();
  d.image = Image8{gray.width, gray.height, 1, std::move(gray.pixels)};
  return d;
}

TrialAnalysis PhotographAndAnalyse(const SyntheticScene& scene, const Image8& display,
                                   const PhotoInput& input, const std::filesystem::path& camera_path,
                                   const AnalyzeOptions& options) {
  TrialAnalysis t;
  const Stopwatch watch;
  t.photo = RenderSyntheticPhoto(scene, display);
  t.photo_ms = watch.Ms();
  t.analysis = AnalyzeImages(scene.camera, camera_path, {input}, {PhotoToMat(t.photo)}, options);
  return t;
}

const ModelFit* CylinderCandidate(const AnalysisResult& result) {
  if (!result.fit) return nullptr;
  const ModelFit* cylinder = nullptr;
  for (const ModelFit& c : result.fit->candidates) {
    if (c.model == "cylinder") cylinder = &c;
  }
  return cylinder;
}

}  // namespace curvecheck::experiments
