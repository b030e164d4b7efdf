#include "core/path_check.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "core/test_util.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;
using ::curvecheck::testing::MessageOf;

class PathCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_path_check_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "file.txt") << "x";
    fs::create_directory(dir_ / "folder");
    fs::create_symlink("loop_b", dir_ / "loop_a");  // loop_a -> loop_b -> loop_a
    fs::create_symlink("loop_a", dir_ / "loop_b");
    fs::create_symlink("self", dir_ / "self");
    fs::create_symlink("file.txt", dir_ / "link_to_file");
    fs::create_symlink("absent", dir_ / "dangling");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(PathCheck, TellsALinkLoopFromAMissingPath) {
  EXPECT_EQ(ClassifyPath(dir_ / "file.txt"), PathKind::kFile);
  EXPECT_EQ(ClassifyPath(dir_ / "link_to_file"), PathKind::kFile);
  EXPECT_EQ(ClassifyPath(dir_ / "folder"), PathKind::kFolder);
  EXPECT_EQ(ClassifyPath(dir_ / "absent"), PathKind::kMissing);
  EXPECT_EQ(ClassifyPath(dir_ / "dangling"), PathKind::kMissing);
  EXPECT_EQ(ClassifyPath(dir_ / "file.txt" / "below"), PathKind::kMissing);  // ENOTDIR
  EXPECT_EQ(ClassifyPath(dir_ / "loop_a"), PathKind::kLinkLoop);
  EXPECT_EQ(ClassifyPath(dir_ / "self"), PathKind::kLinkLoop);
  EXPECT_EQ(ClassifyPath(dir_ / "loop_a" / "photo.png"), PathKind::kLinkLoop);  // a loop on the way
  EXPECT_EQ(ClassifyPath("/dev/null"), PathKind::kOther);
}

TEST_F(PathCheck, RequireFileAndFolderNameThePathTheProblemAndTheFix) {
  EXPECT_EQ(MessageOf([&] { RequireFile(dir_ / "file.txt"); }), "(no error)");
  EXPECT_EQ(MessageOf([&] { RequireFile("/dev/null"); }), "(no error)");
  EXPECT_EQ(MessageOf([&] { RequireFile(dir_ / "absent"); }),
            (dir_ / "absent").string() + ": file does not exist; check the path");
  EXPECT_EQ(MessageOf([&] { RequireFile(dir_ / "self"); }),
            (dir_ / "self").string() +
                ": is a symbolic link loop; make the link point at an existing file or folder (ls -l shows where it "
                "leads)");
  EXPECT_EQ(MessageOf([&] { RequireFile(dir_ / "folder"); }),
            (dir_ / "folder").string() + ": is a folder, not a file; give a file");
  EXPECT_EQ(MessageOf([&] { RequireFolder(dir_ / "folder", "give a folder"); }), "(no error)");
  EXPECT_EQ(MessageOf([&] { RequireFolder(dir_ / "file.txt", "give a folder"); }),
            (dir_ / "file.txt").string() + ": is not a folder; give a folder");
  EXPECT_THAT(MessageOf([&] { RequireFolder(dir_ / "loop_b", "give a folder"); }),
              ::testing::HasSubstr("loop_b: is a symbolic link loop; "));
}

}  // namespace
}  // namespace curvecheck
