#include "pattern/pattern_json.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <functional>

#include "core/error.h"
#include "core/file_io.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using testing::EigenNear;
using ::testing::HasSubstr;
using ::testing::StartsWith;

class PatternJson : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_pattern_json_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    monitor_ = MonitorFromDiagonal("49", 5120, 1440, 49, 1000);
    PatternSpec spec;
    spec.kind = PatternKind::kBoth;
    spec.cols = 6;
    spec.rows = 4;
    spec.first_tag_id = 3;
    pattern_ = BuildPattern(spec, monitor_, viewpoint_, TangentPlaneAtCentre(monitor_));
  }
  void TearDown() override { fs::remove_all(dir_); }

  json Document() const {
    return PatternToJson(pattern_, monitor_, viewpoint_, {{"name", "exact"}, {"aa", "analytic"}});
  }

  // Writes `text` as a pattern.json and returns ReadPatternJson's error message.
  std::string ReadError(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    WriteFileAtomic(path, text);
    try {
      ReadPatternJson(path);
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_THAT(msg, StartsWith(path.string() + ": ")) << "the message names the file";
      EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line";
      return msg;
    }
    return "(no error)";
  }
  std::string ReadError(const std::string& name, const std::function<void(json&)>& edit) const {
    json j = Document();
    edit(j);
    return ReadError(name, j.dump(1));
  }

  fs::path dir_;
  Monitor monitor_;
  Eigen::Vector3d viewpoint_{350, 120, 150};
  Pattern pattern_;
};

TEST_F(PatternJson, DocumentFollowsTheContract) {
  const json j = Document();
  EXPECT_EQ(j["format"], "curvecheck.pattern/1");
  EXPECT_EQ(j["method"], "exact");
  EXPECT_EQ(j["method_parameters"], json({{"name", "exact"}, {"aa", "analytic"}}));
  EXPECT_EQ(j["monitor"]["resolution"], json({5120, 1440}));
  EXPECT_EQ(j["monitor"]["radius_mm"], 1000.0);
  EXPECT_EQ(j["viewpoint_mm"], json({350.0, 120.0, 150.0}));
  const json& pj = j["pattern"];
  EXPECT_EQ(pj["kind"], "both");
  EXPECT_EQ(pj["cols"], 6);
  EXPECT_EQ(pj["rows"], 4);
  EXPECT_EQ(pj["square_mm"], pattern_.spec.square_mm);
  EXPECT_EQ(pj["tag_mm"], pattern_.spec.tag_mm);
  EXPECT_EQ(pj["tag_ids"], json({3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14}));
  EXPECT_EQ(pj["plane"]["origin_mm"], json({0.0, 0.0, -1000.0}));
  EXPECT_EQ(pj["cells"]["width"], 72);
  EXPECT_EQ(pj["cells"]["height"], 48);
  EXPECT_EQ(pj["cells"]["cell_mm"], pattern_.cells.cell_mm);
  EXPECT_FALSE(pj["cells"].contains("values"));
  ASSERT_EQ(j["features"].size(), 63u);
  const json& f = j["features"][15];
  EXPECT_EQ(f["id"], "t3.0");
  EXPECT_EQ(f["kind"], "tag_corner");
  EXPECT_EQ(f["pattern_mm"][0], pattern_.features[15].pattern_mm.x());
  EXPECT_EQ(f["point_mm"][2], -1000.0);
  EXPECT_EQ(f["display_px"][1], pattern_.features[15].display_px->y());
  EXPECT_EQ(f["visible"], true);

  EXPECT_THROW(PatternToJson(pattern_, monitor_, viewpoint_, {{"aa", "analytic"}}), Error);
  EXPECT_THROW(PatternToJson(pattern_, monitor_, viewpoint_, "exact"), Error);
}

TEST_F(PatternJson, RoundTripThroughAFileKeepsEveryFeature) {
  pattern_.features[2].display_px.reset();  // a ray that misses the surface is written as null
  pattern_.features[2].visible = false;
  const fs::path path = dir_ / "pattern.json";
  WriteFileAtomic(path, Document().dump(2));
  const PatternFile file = ReadPatternJson(path);
  EXPECT_EQ(file.method, "exact");
  EXPECT_EQ(file.raw["method_parameters"]["aa"], "analytic");
  EXPECT_EQ(file.monitor.width_px, 5120);
  EXPECT_EQ(file.monitor.height_px, 1440);
  EXPECT_EQ(file.monitor.width_mm, monitor_.width_mm);
  EXPECT_EQ(file.monitor.height_mm, monitor_.height_mm);
  EXPECT_NEAR(file.monitor.radius_mm(), 1000, 1e-12);
  EXPECT_THAT(file.viewpoint_in_screen, EigenNear(viewpoint_, 0));
  ASSERT_EQ(file.features.size(), pattern_.features.size());
  for (size_t i = 0; i < file.features.size(); ++i) {
    const Feature& a = pattern_.features[i];
    const Feature& b = file.features[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.kind, a.kind);
    EXPECT_THAT(b.pattern_mm, EigenNear(a.pattern_mm, 1e-12));
    EXPECT_THAT(b.point_in_screen, EigenNear(a.point_in_screen, 1e-12));
    ASSERT_EQ(b.display_px.has_value(), a.display_px.has_value()) << a.id;
    if (a.display_px) {
      EXPECT_THAT(*b.display_px, EigenNear(*a.display_px, 1e-12));
    }
    EXPECT_EQ(b.visible, a.visible);
  }
  EXPECT_FALSE(file.features[2].display_px.has_value());

  // A flat monitor is written and read as "flat".
  const Monitor flat = MonitorFromDiagonal("27", 2560, 1440, 27, 0);
  const Pattern p = BuildPattern(PatternSpec{}, flat, {0, 0, 600}, TangentPlaneAtCentre(flat));
  WriteFileAtomic(path, PatternToJson(p, flat, {0, 0, 600}, {{"name", "none"}}).dump());
  const PatternFile f2 = ReadPatternJson(path);
  EXPECT_TRUE(f2.monitor.is_flat());
  EXPECT_EQ(f2.raw["monitor"]["radius_mm"], "flat");
  EXPECT_EQ(f2.method, "none");
  EXPECT_EQ(f2.features.size(), 60u);
}

// ParsePatternJson (the text entry point, used by the fuzzer) reads what ReadPatternJson reads, with `source` in
// its errors.
TEST_F(PatternJson, ParseFromTextNamesTheSource) {
  const PatternFile p = ParsePatternJson(Document().dump(), "mem.json");
  EXPECT_EQ(p.features.size(), pattern_.features.size());
  EXPECT_THAT(testing::MessageOf([] { ParsePatternJson("{}", "mem.json"); }),
              StartsWith("mem.json: 'format' is missing"));
}

// Deep nesting: a 20 kB file of nested lists overflowed the stack in the finiteness check (recursion with a
// path string per level); any nesting beyond 32 levels is refused (the document nests 4).
TEST_F(PatternJson, DeeplyNestedDocumentsAreRefused) {
  const int n = 100000;
  const std::string deep = "{\"pattern\": " + std::string(n, '[') + std::string(n, ']') + "}";
  EXPECT_THAT(ReadError("deep.json", deep), HasSubstr("is nested more than 32 levels deep"));
  // Depth counts from the top-level object (0): pattern 1, extra 2, k lists around a number put it at 2 + k.
  const auto nested = [&](int k) {
    json j = Document();
    j["pattern"]["extra"] = json::parse(std::string(k, '[') + "1" + std::string(k, ']'));
    return j.dump();
  };
  EXPECT_EQ(ReadError("deep30.json", nested(30)), "(no error)");
  EXPECT_THAT(ReadError("deep31.json", nested(31)), HasSubstr("'pattern.extra[0][0]"));
  EXPECT_THAT(ReadError("deep31.json", nested(31)), HasSubstr("is nested more than 32 levels deep"));
}

TEST_F(PatternJson, DamagedFilesAreRejectedNamingTheFileAndTheEntry) {
  const std::string good = Document().dump(1);
  EXPECT_EQ(ReadError("good.json", good), "(no error)");
  EXPECT_THAT(ReadError("truncated.json", good.substr(0, good.size() / 2)), HasSubstr("is not valid JSON"));
  EXPECT_THAT(ReadError("empty.json", ""), HasSubstr("is not valid JSON"));
  EXPECT_THAT(ReadError("list.json", "[1, 2]"), HasSubstr("'(top level)' must be an object"));
  EXPECT_THAT(ReadError("overflow.json", R"({"format": 1e999})"), HasSubstr("is not valid JSON"));
  EXPECT_THAT(ReadError("format.json", [](json& j) { j["format"] = "curvecheck.pattern/2"; }),
              HasSubstr("'format' is \"curvecheck.pattern/2\", not \"curvecheck.pattern/1\""));
  EXPECT_THAT(ReadError("no_format.json", [](json& j) { j.erase("format"); }),
              HasSubstr("'format' is missing"));
  EXPECT_THAT(ReadError("no_monitor.json", [](json& j) { j.erase("monitor"); }),
              HasSubstr("'monitor' is missing"));
  EXPECT_THAT(ReadError("radius.json", [](json& j) { j["monitor"]["radius_mm"] = -5; }),
              HasSubstr("'monitor.radius_mm' is -5; it must be positive or \"flat\""));
  EXPECT_THAT(ReadError("radius_word.json", [](json& j) { j["monitor"]["radius_mm"] = "curved"; }),
              HasSubstr("'monitor.radius_mm' must be a number, got \"curved\""));
  EXPECT_THAT(ReadError("resolution.json", [](json& j) { j["monitor"]["resolution"][0] = 0; }),
              HasSubstr("'monitor.resolution[0]' must be a whole number of at least 1, got 0"));
  EXPECT_THAT(ReadError("pixels.json", [](json& j) { j["monitor"]["width_mm"] = 2000.0; }),
              HasSubstr("pixels are not square"));
  EXPECT_THAT(ReadError("viewpoint.json",
                        [](json& j) {
                          j["viewpoint_mm"] = {0, 0};
                        }),
              HasSubstr("'viewpoint_mm' must be a list of 3 numbers"));
  EXPECT_THAT(ReadError("behind.json",
                        [](json& j) {
                          j["viewpoint_mm"] = {0, 0, -1500};
                        }),
              HasSubstr("viewpoint"));
  EXPECT_THAT(ReadError("method.json", [](json& j) { j["method"] = j["method_parameters"]; }),
              HasSubstr("'method' must be a text"));
  EXPECT_THAT(ReadError("pattern.json", [](json& j) { j.erase("pattern"); }),
              HasSubstr("'pattern' is missing"));
  EXPECT_THAT(ReadError("nan_string.json", [](json& j) { j["features"][3]["display_px"][0] = "NaN"; }),
              HasSubstr("'features[3].display_px[0]' must be a number, got \"NaN\""));
  {  // NaN written as a bare word: JSON has no NaN, the parser refuses it.
    json j = Document();
    j["features"][3]["display_px"][0] = 12345.25;
    std::string text = j.dump(1);
    text.replace(text.find("12345.25"), 8, "NaN");
    EXPECT_THAT(ReadError("nan_literal.json", text), HasSubstr("is not valid JSON"));
  }
  EXPECT_THAT(ReadError("duplicate.json", [](json& j) { j["features"][5]["id"] = j["features"][4]["id"]; }),
              HasSubstr("'features[5].id' 'c4' appears twice"));
  for (const char* bad : {"t7.4", "t587.0", "c01", "c", "x3", "t3", "c-1", "t.1", "t3.0.1", "c1 "}) {
    EXPECT_THAT(ReadError("id.json", [&](json& j) { j["features"][0]["id"] = bad; }),
                HasSubstr(fmt::format("'features[0].id' is '{}', not a feature id", bad)));
  }
  EXPECT_THAT(ReadError("kind.json", [](json& j) { j["features"][0]["kind"] = "tag_corner"; }),
              HasSubstr("'features[0].kind' is 'tag_corner', but feature 'c0' is a corner"));
  EXPECT_THAT(ReadError("no_features.json", [](json& j) { j["features"] = json::array(); }),
              HasSubstr("'features' must be a non-empty list"));
  EXPECT_THAT(ReadError("point.json", [](json& j) { j["features"][7].erase("point_mm"); }),
              HasSubstr("'features[7].point_mm' is missing"));
  EXPECT_THAT(ReadError("visible.json", [](json& j) { j["features"][7]["visible"] = 1; }),
              HasSubstr("'features[7].visible' must be true or false"));
  EXPECT_THAT(ReadError("visible_null.json", [](json& j) { j["features"][7]["display_px"] = nullptr; }),
              HasSubstr("'features[7]' is visible but has no display_px"));

  try {
    ReadPatternJson(dir_ / "missing.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("missing.json: file does not exist"));
  }
}

}  // namespace
}  // namespace curvecheck
