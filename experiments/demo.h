// `curvecheck demo`: the main job on the embedded default, end to end: render a corrected checkerboard for
// the default scene's camera position (exact method, Vulkan), photograph it with the synthetic camera (the
// default scene: 49" 1000R monitor, 24 MP OPENCV8 camera 1.5 m in front of the centre, an ideal true
// monitor), and analyse the photo (detect, verify, fit the screen).
#pragma once

#include <filesystem>
#include <ostream>

namespace curvecheck::experiments {

// Runs the demo into `out`, an existing writable folder: pattern.png + .json, photo.png + .truth.json, the
// embedded datasets (datasets/: what the outputs came from), analysis/result.json, report.html and the
// overlay. Prints each stage, the summary and the radius against the truth to `log`. Returns true when the
// verification passes and the true radius is inside the fit's 95% interval. Throws Error when the photo
// cannot be analysed at all (a bug).
bool RunDemo(const std::filesystem::path& out, std::ostream& log);

}  // namespace curvecheck::experiments
