// libFuzzer target: the .cameramodel reader (core/camera_model.h ParseCameraModel, through libmrcal's parser),
// and, for a model it accepts, one projection and one unprojection through libmrcal: a model that passes
// CameraModel::Check() must be usable by the synthetic camera and the fit. libmrcal itself is not instrumented
// (Debian's build), so libFuzzer's coverage guidance ends at its API; ASan still sees its heap.
// Seeds: fuzz/corpus/fuzz_cameramodel (datasets/cameras/*.cameramodel and small models of other lens types).
#include <cstddef>
#include <cstdint>

#include "core/camera_model.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  const std::string text = fuzz::Text(data, size);
  fuzz::ParsesOrThrowsError([&] {
    const CameraModel m = ParseCameraModel(text, "fuzz.cameramodel");
    ProjectPoint(m, Eigen::Vector3d(0.1, -0.2, 1.0));
    UnprojectPixels(m, {Eigen::Vector2d(0.5 * (m.width - 1), 0.5 * (m.height - 1))});
  });
  return 0;
}
