// Scenes by embedded name: every embedded scene loads from the binary with its camera model (nothing written
// to disk), and equals the same scene read from its file in datasets/; unknown names fail naming the option.
#include "experiments/scene_lookup.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "core/error.h"

namespace curvecheck::experiments {
namespace {

using ::testing::HasSubstr;

TEST(SceneLookup, EveryEmbeddedSceneLoadsAsItsFileDoes) {
  const std::vector<std::string> names = EmbeddedSceneNames();
  ASSERT_GE(names.size(), 7u);
  const char* source = std::getenv("CURVECHECK_SOURCE_DIR");
  ASSERT_NE(source, nullptr);
  for (const std::string& name : names) {
    const SyntheticScene embedded = LoadEmbeddedScene(name, "--scene");
    const SyntheticScene file =
        LoadScene(std::filesystem::path(source) / "datasets" / "scenes" / (name + ".yaml"));
    EXPECT_EQ(embedded.camera_model_path, file.camera_model_path) << name;
    EXPECT_EQ(embedded.camera.lensmodel, file.camera.lensmodel) << name;
    EXPECT_EQ(embedded.camera.intrinsics, file.camera.intrinsics) << name;
    EXPECT_EQ(embedded.camera.width, file.camera.width) << name;
    EXPECT_TRUE(embedded.screen_from_cam.translation.isApprox(file.screen_from_cam.translation)) << name;
    EXPECT_EQ(embedded.truth.curvature_per_mm, file.truth.curvature_per_mm) << name;
    EXPECT_EQ(embedded.monitor.name, file.monitor.name) << name;
  }
}

TEST(SceneLookup, FindSceneTakesAFileOrAName) {
  EXPECT_EQ(FindScene("default", "--scene").monitor.name,
            LoadEmbeddedScene("default", "--scene").monitor.name);
  try {
    FindScene("no-such-scene", "--scene");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("--scene"));
    EXPECT_THAT(e.what(), HasSubstr("'no-such-scene' is neither a file nor an embedded scene"));
  }
  EXPECT_THROW(LoadEmbeddedScene("no-such-scene", "--scenes"), Error);
  EXPECT_EQ(SceneSource("default"), "embedded scene default");
}

}  // namespace
}  // namespace curvecheck::experiments
