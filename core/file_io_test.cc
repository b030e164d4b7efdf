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

TEST_F(FileIo, OutputSetPublishesAllOrNothing) {
  WriteFileAtomic(dir_ / "result.json", "old result");
  WriteFileAtomic(dir_ / "report.html", "old report");
  WriteFileAtomic(dir_ / "overlay-a.png", "old overlay");
  {
    OutputSet dropped;  // a run that fails before publishing
    dropped.Write(dir_ / "result.json", "new result");
    const fs::path staged = dropped.Stage(dir_ / "report.html");
    EXPECT_EQ(staged.extension(), ".html");  // writers that choose the format by extension still can
    EXPECT_THAT(staged.filename().string(), HasSubstr(".tmp"));
    WriteFileAtomic(staged, "new report");
    EXPECT_EQ(ReadFileToString(dir_ / "result.json"), "old result");
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 3);  // staged files gone
  EXPECT_EQ(ReadFileToString(dir_ / "report.html"), "old report");

  OutputSet set;
  set.Write(dir_ / "result.json", "new result");
  set.Write(dir_ / "overlay-a.png", "new overlay");
  set.RemoveOnPublish(dir_ / "report.html");  // a run with --no-report: the old page described the old result
  set.RemoveOnPublish(dir_ / "never-there.png");
  EXPECT_EQ(ReadFileToString(dir_ / "result.json"), "old result");
  set.Publish();
  EXPECT_EQ(ReadFileToString(dir_ / "result.json"), "new result");
  EXPECT_EQ(ReadFileToString(dir_ / "overlay-a.png"), "new overlay");
  EXPECT_FALSE(fs::exists(dir_ / "report.html"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 2);
}

TEST_F(FileIo, AWriterFailingOnAStagedFileNamesTheTarget) {
  OutputSet set;
  try {
    set.WriteWith(dir_ / "x.png", [](const fs::path& staged) {
      throw Error(staged.string(), "write failed: File too large", "free disk space and run again");
    });
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir_ / "x.png").string() + ": write failed: File too large; free disk space and run again");
  }
}

TEST_F(FileIo, CheckWritableSaysWhatWriteFileAtomicWouldSay) {
  CheckWritable(dir_ / "out.json");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 0);  // the probe is gone
  try {
    CheckWritable(dir_ / "nope" / "out.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("out.json: output folder '"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("nope' does not exist; create it first"));
  }
  EXPECT_THROW(CheckWritable("/proc/curvecheck_out.json"), Error);
  EXPECT_THROW(CheckWritable(dir_), Error);  // a folder where a file is to go
}

TEST_F(FileIo, FolderLockRefusesASecondHolderAndNamesThePid) {
  {
    const FolderLock lock(dir_, "-o");
    EXPECT_EQ(ReadFileToString(dir_ / FolderLock::kFileName), std::to_string(::getpid()) + "\n");
    try {
      const FolderLock second(dir_, "-o");  // flock(2) locks conflict between open files, even in one process
      FAIL();
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                "-o: folder '" + dir_.string() + "' is in use by another curvecheck run (pid " +
                    std::to_string(::getpid()) + "); wait for it to finish, or choose another output folder");
    }
  }
  EXPECT_FALSE(fs::exists(dir_ / FolderLock::kFileName));  // nothing left in the user's folder
  const FolderLock again(dir_, "-o");
  EXPECT_TRUE(fs::exists(dir_ / FolderLock::kFileName));
}

}  // namespace
}  // namespace curvecheck
