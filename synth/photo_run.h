// `curvecheck capture synth --scene SCENE.yaml --display pattern.png -o photo.png` once its options are parsed
// (app/capture_synth_command.cc): the synthetic camera's photo with its truth and camera model, written as one set
// after every output was checked against every input. Errors name the option at fault.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace curvecheck {

struct SynthPhotoRequest {
  std::string scene, display, output;
  double ray_grid_px = 16;
  std::vector<std::string> overrides;  // --set KEY=VALUE
  std::optional<double> scale;         // --scale: imager scale
};

// Writes PHOTO (.png, or .jpg: the realistic chain's JPEG), PHOTO.truth.json (the true image position of every
// feature of the display's pattern.json, which must sit beside it; X.png.truth.json when X.truth.json is an input)
// and PHOTO.cameramodel (the scene's camera at request.scale); the timing and what was written on `log`.
void TakeSyntheticPhoto(const SynthPhotoRequest& request, std::ostream& log);

}  // namespace curvecheck
