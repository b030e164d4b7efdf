// truth.json, the synthetic photo's ground truth. Part of the synthetic camera's public interface
// (synth/synthetic_camera.h includes it).
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "synth/scene.h"

namespace curvecheck {

struct Feature;

// truth.json: format curvecheck.truth/1 with the true geometry, the camera (model and pose) and, for each
// feature, its true image position (forward projection of the true surface point where the display shows it)
// and visibility (on the display, in front of the camera, facing it, inside the image).
nlohmann::json TruthJson(const SyntheticScene& scene, const std::vector<Feature>& features);

}  // namespace curvecheck
