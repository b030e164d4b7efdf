#include "capture/session.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "core/file_io.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using nlohmann::json;
using testing::MessageOf;

class Session : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_session_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "patterns");
    WritePattern("a", 10);
    WritePattern("b", 200);
    plan_file_ = dir_ / "plan.yaml";
    std::ofstream(plan_file_) << "shots:\n"
                                 "  - pattern: patterns/a.png\n    viewpoint_mm: [0, 0, -1500]\n    repeat: 2\n"
                                 "  - pattern: patterns/b.png\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  void WritePattern(const std::string& name, int grey) {
    cv::imwrite((dir_ / "patterns" / (name + ".png")).string(), cv::Mat(8, 16, CV_8UC1, cv::Scalar(grey)));
    std::ofstream(dir_ / "patterns" / (name + ".json")) << R"({"format": "curvecheck.pattern/1", "name": ")" << name
                                                        << "\"}\n";
  }
  static FakeSource Frames() {
    return FakeSource([](int grab) { return cv::Mat(6, 9, CV_8UC3, cv::Scalar(grab, 2 * grab, 3 * grab)); });
  }
  json Manifest(const fs::path& folder) { return json::parse(ReadFileToString(folder / kManifestName)); }

  fs::path dir_, plan_file_;
};

TEST_F(Session, PlanExpandsRepeatsAndFindsPatternJson) {
  const SessionPlan plan = LoadSessionPlan(plan_file_);
  ASSERT_EQ(plan.shots.size(), 3u);
  EXPECT_EQ(plan.shots[1].pattern_json, dir_ / "patterns" / "a.json");
  EXPECT_THAT(*plan.shots[0].viewpoint_mm, ElementsAre(0, 0, -1500));
  EXPECT_FALSE(plan.shots[2].viewpoint_mm.has_value());
}

TEST_F(Session, PlanErrorsNameTheShot) {
  std::ofstream(dir_ / "typo.yaml") << "shots:\n  - pattern: patterns/a.png\n    repeats: 2\n";
  EXPECT_THAT(MessageOf([&] { LoadSessionPlan(dir_ / "typo.yaml"); }),
              HasSubstr("shots[0]: key 'repeats' is not a known key"));
  fs::remove(dir_ / "patterns" / "b.json");
  EXPECT_THAT(MessageOf([&] { LoadSessionPlan(plan_file_); }), HasSubstr("shots[1]: pattern.json"));
  std::ofstream(dir_ / "empty.yaml") << "shots: []\n";
  EXPECT_THAT(MessageOf([&] { LoadSessionPlan(dir_ / "empty.yaml"); }), HasSubstr("non-empty list"));
}

TEST_F(Session, ThreeShotsWithAFakeSource) {
  const SessionPlan plan = LoadSessionPlan(plan_file_);
  FakeSource source = Frames();
  std::vector<size_t> shown;
  std::ostringstream log;
  Progress progress("capture", 3, log, false);
  const SessionResult r = RunSession(
      plan, source, [&](size_t i, const PlannedShot&) { shown.push_back(i); }, {dir_ / "s", false, "test"}, &progress);
  EXPECT_EQ(r.taken, 3);
  EXPECT_THAT(shown, ElementsAre(0, 1, 2));
  EXPECT_EQ(log.str(), "capture: 1/3 shot_0001.png\ncapture: 2/3 shot_0002.png\ncapture: 3/3 shot_0003.png\n");
  const json m = Manifest(dir_ / "s");
  EXPECT_EQ(m["format"], "curvecheck.session/1");
  ASSERT_EQ(m["shots"].size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const json& s = m["shots"][static_cast<size_t>(i)];
    EXPECT_EQ(s["photo"], fmt::format("shot_{:04d}.png", i + 1));
    EXPECT_EQ(cv::imread((dir_ / "s" / s["photo"].get<std::string>()).string()).at<cv::Vec3b>(0, 0)[0], i + 1);
    EXPECT_TRUE(fs::exists(dir_ / "s" / s["pattern"].get<std::string>()));
    EXPECT_TRUE(fs::exists(dir_ / "s" / s["pattern_json"].get<std::string>()));
    EXPECT_THAT(s["time_utc"].get<std::string>(), HasSubstr("Z"));
    EXPECT_EQ(s["source"], "fake (generated frames)");
  }
  // Pattern a was shown twice and stored once.
  EXPECT_EQ(m["shots"][0]["pattern"], m["shots"][1]["pattern"]);
  EXPECT_NE(m["shots"][0]["pattern"], m["shots"][2]["pattern"]);
  EXPECT_EQ(m["shots"][0]["viewpoint_mm"], json({0, 0, -1500}));
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_ / "s")) ++files;
  EXPECT_EQ(files, 3 + 4 + 1);  // photos, two pattern pairs, manifest
  // Running again into the same folder without --resume refuses.
  FakeSource again = Frames();
  EXPECT_THAT(MessageOf([&] { RunSession(plan, again, [](size_t, const PlannedShot&) {}, {dir_ / "s", false, ""}); }),
              HasSubstr("exists and is not empty; continue it with --resume"));
}

TEST_F(Session, InterruptedSessionKeepsItsShotsAndResumes) {
  const SessionPlan plan = LoadSessionPlan(plan_file_);
  FakeSource failing = Frames();
  failing.FailAt(2, "USB camera disconnected");
  const fs::path s = dir_ / "s";
  EXPECT_EQ(MessageOf([&] { RunSession(plan, failing, [](size_t, const PlannedShot&) {}, {s, false, ""}); }),
            s.string() + ": session stopped at shot 2/3: fake source: USB camera disconnected; the 1 shot taken are "
                         "in its manifest; fix the cause and rerun with --resume");
  ASSERT_EQ(Manifest(s)["shots"].size(), 1u);
  EXPECT_FALSE(fs::exists(s / "shot_0002.png"));
  const std::string first = ReadFileToString(s / "shot_0001.png");
  const auto first_time = fs::last_write_time(s / "shot_0001.png");
  ::usleep(20000);

  FakeSource later([](int) { return cv::Mat(6, 9, CV_8UC3, cv::Scalar(77, 77, 77)); });
  std::vector<size_t> shown;
  std::ostringstream log;
  Progress progress("capture", 3, log, false);
  const SessionResult r =
      RunSession(plan, later, [&](size_t i, const PlannedShot&) { shown.push_back(i); }, {s, true, ""}, &progress);
  EXPECT_EQ(r.resumed_after, 1);
  EXPECT_EQ(r.taken, 2);
  EXPECT_THAT(shown, ElementsAre(1, 2));
  EXPECT_EQ(log.str(), "capture: 2/3 shot_0002.png\ncapture: 3/3 shot_0003.png\n");
  EXPECT_EQ(ReadFileToString(s / "shot_0001.png"), first);
  EXPECT_EQ(fs::last_write_time(s / "shot_0001.png"), first_time);
  const json m = Manifest(s);
  ASSERT_EQ(m["shots"].size(), 3u);
  EXPECT_EQ(m["shots"][2]["photo"], "shot_0003.png");
  EXPECT_EQ(later.grabs(), 2);
}

TEST_F(Session, ResumeNeverOverwritesAStrayShotFile) {
  const SessionPlan plan = LoadSessionPlan(plan_file_);
  FakeSource failing = Frames();
  failing.FailAt(2, "stop");
  const fs::path s = dir_ / "s";
  MessageOf([&] { RunSession(plan, failing, [](size_t, const PlannedShot&) {}, {s, false, ""}); });
  std::ofstream(s / "shot_0002.png") << "left by a crash";
  FakeSource source = Frames();
  EXPECT_THAT(MessageOf([&] { RunSession(plan, source, [](size_t, const PlannedShot&) {}, {s, true, ""}); }),
              HasSubstr("shot_0002.png: exists but is not in the manifest"));
  EXPECT_EQ(ReadFileToString(s / "shot_0002.png"), "left by a crash");
  EXPECT_EQ(Manifest(s)["shots"].size(), 1u);
}

TEST_F(Session, ResumeNeedsAManifestOfThisPlan) {
  const SessionPlan plan = LoadSessionPlan(plan_file_);
  FakeSource source = Frames();
  EXPECT_THAT(MessageOf([&] { RunSession(plan, source, [](size_t, const PlannedShot&) {}, {dir_ / "x", true, ""}); }),
              HasSubstr("has no manifest.json to resume"));
}

TEST_F(Session, ImportCopiesReadablePhotosAndRejectsCorruptOnes) {
  const fs::path photos = dir_ / "photos";
  fs::create_directories(photos);
  cv::imwrite((photos / "IMG_0002.png").string(), cv::Mat(5, 7, CV_8UC3, cv::Scalar(2, 2, 2)));
  cv::imwrite((photos / "IMG_0001.png").string(), cv::Mat(5, 7, CV_8UC3, cv::Scalar(1, 1, 1)));
  std::ofstream(photos / "IMG_0003.png") << "\x89PNG\r\n\x1a\n truncated garbage";
  std::ofstream(photos / "notes.txt") << "not a photo";
  const std::string original = ReadFileToString(photos / "IMG_0002.png");
  const auto original_time = fs::last_write_time(photos / "IMG_0002.png");

  std::ostringstream log;
  Progress progress("import", 2, log, false);
  const ImportResult r = ImportFolder(photos, dir_ / "patterns" / "a.json", dir_ / "s", "test", &progress);
  EXPECT_EQ(r.imported, 2);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_EQ(r.rejected[0].first, "IMG_0003.png");
  EXPECT_THAT(r.rejected[0].second, HasSubstr("not a readable image"));
  const json m = Manifest(dir_ / "s");
  ASSERT_EQ(m["shots"].size(), 2u);
  EXPECT_EQ(m["shots"][0]["photo"], "shot_0001.png");
  EXPECT_EQ(m["shots"][0]["original"], (photos / "IMG_0001.png").string());  // sorted by name
  EXPECT_EQ(m["shots"][1]["original"], (photos / "IMG_0002.png").string());
  EXPECT_EQ(ReadFileToString(dir_ / "s" / "shot_0002.png"), original);
  EXPECT_TRUE(fs::exists(dir_ / "s" / m["shots"][0]["pattern"].get<std::string>()));
  EXPECT_TRUE(fs::exists(dir_ / "s" / m["shots"][0]["pattern_json"].get<std::string>()));
  EXPECT_EQ(m["rejected"][0]["file"], "IMG_0003.png");
  // The originals are untouched and still there.
  EXPECT_EQ(ReadFileToString(photos / "IMG_0002.png"), original);
  EXPECT_EQ(fs::last_write_time(photos / "IMG_0002.png"), original_time);
  EXPECT_TRUE(fs::exists(photos / "IMG_0003.png"));
  EXPECT_EQ(log.str(), "import: 1/2 shot_0001.png\nimport: 2/2 shot_0002.png\n");
  // A second import into the same folder refuses.
  EXPECT_THAT(MessageOf([&] { ImportFolder(photos, dir_ / "patterns" / "a.json", dir_ / "s"); }),
              HasSubstr("exists and is not empty"));
}

// The import decodes through DecodeImage8 too: a PNG whose header declares 30000 x 30000 px (OpenCV would
// allocate 2.7 GB for it) is rejected with the reason, and the good photo is imported.
TEST_F(Session, ImportRejectsAPhotoDeclaringTooManyPixels) {
  const fs::path photos = dir_ / "photos";
  fs::create_directories(photos);
  std::vector<uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(5, 7, CV_8UC3, cv::Scalar(1, 2, 3)), png));
  std::ofstream(photos / "IMG_0001.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                                                  static_cast<std::streamsize>(png.size()));
  std::string huge(png.begin(), png.end());
  for (int i : {16, 20}) huge.replace(static_cast<size_t>(i), 4, std::string("\x00\x00\x75\x30", 4));
  std::ofstream(photos / "IMG_0002.png", std::ios::binary) << huge;
  const ImportResult r = ImportFolder(photos, dir_ / "patterns" / "a.json", dir_ / "s");
  EXPECT_EQ(r.imported, 1);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_EQ(r.rejected[0].first, "IMG_0002.png");
  EXPECT_THAT(r.rejected[0].second, HasSubstr("not a readable image: declares 30000 x 30000 px"));
  EXPECT_EQ(Manifest(dir_ / "s")["shots"][0]["metadata"]["width"], 7);
}

}  // namespace
}  // namespace curvecheck
