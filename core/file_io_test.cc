#include "core/file_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

class FileIo : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_file_io_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(FileIo, AtomicWriteCreatesAndReplacesLeavingNoTemporary) {
  const fs::path p = dir_ / "out.json";
  WriteFileAtomic(p, "first");
  EXPECT_EQ(ReadFileToString(p), "first");
  WriteFileAtomic(p, "second, longer");
  EXPECT_EQ(ReadFileToString(p), "second, longer");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(FileIo, MissingFolderAndUnwritablePlaceAreClearErrors) {
  try {
    WriteFileAtomic(dir_ / "nope" / "out.json", "x");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("does not exist"));
  }
  // /proc refuses new files even for root.
  EXPECT_THROW(WriteFileAtomic("/proc/curvecheck_out.json", "x"), Error);
}

TEST_F(FileIo, ReadingMissingFileOrFolder) {
  try {
    ReadFileToString(dir_ / "missing.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("missing.yaml: file does not exist"));
  }
  EXPECT_THROW(ReadFileToString(dir_), Error);
}

}  // namespace
}  // namespace curvecheck
