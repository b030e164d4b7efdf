// libFuzzer target: the synthetic camera's scene reader (synth/synthetic_camera.h SceneFromConfig), on top of
// ConfigMap, the monitor presets and the .cameramodel reader. Relative paths in the scene resolve against
// datasets/scenes/ of the source tree (CURVECHECK_SCENE_DIR), as for the committed scenes.
// Seeds: fuzz/corpus/fuzz_scene (datasets/scenes/*.yaml).
#include <cstddef>
#include <cstdint>

#include "synth/synthetic_camera.h"
#include "core/config.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  const std::string text = fuzz::Text(data, size);
  fuzz::ParsesOrThrowsError([&] { SceneFromConfig(ConfigMap::Parse(text, "fuzz.yaml"), CURVECHECK_SCENE_DIR); });
  return 0;
}
