// The embedded dataset files are the files of datasets/, byte for byte, and a scene written out loads.
#include "datasets/dataset_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {

TEST(DatasetFilesTest, EmbeddedFilesEqualTheSourceFiles) {
  const std::filesystem::path source = std::filesystem::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "datasets";
  const std::vector<std::string> names = DatasetFileNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "scenes/default.yaml"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "cameras/default-24mp-opencv8.cameramodel"), names.end());
  for (const std::string& name : names) EXPECT_EQ(DatasetFileText(name), ReadFileToString(source / name)) << name;
}

TEST(DatasetFilesTest, WritesOnceAndNeverOverwritesOtherContent) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "dataset_files_test";
  std::filesystem::remove_all(dir);
  WriteDatasetFiles(dir);
  EXPECT_EQ(ReadFileToString(dir / "scenes/default.yaml"), DatasetFileText("scenes/default.yaml"));
  WriteDatasetFiles(dir);  // same content: fine
  WriteFileAtomic(dir / "scenes/default.yaml", "edited\n");
  EXPECT_THROW(WriteDatasetFiles(dir), Error);
  EXPECT_EQ(ReadFileToString(dir / "scenes/default.yaml"), "edited\n");
}

}  // namespace
}  // namespace curvecheck
