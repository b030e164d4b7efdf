// The result.json reader: real documents written by `curvecheck analyze` (the fuzz corpus) are read; documents
// broken in one place are refused with one line naming the file and the key. What it does not prove: that every
// document analyze can write is accepted (analyze's own output is checked by ReportHtml on every run, and the
// end-to-end tests run analyze).
#include "analysis/result_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;

fs::path Corpus(const std::string& name) {
  return fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "fuzz/corpus/fuzz_result_json" / name;
}

json Good() { return json::parse(ReadFileToString(Corpus("cylinder-1080r.json"))); }

// The one-line message ParseResultJson gives for `doc`, or "" when it is accepted.
std::string RefusalOfText(const std::string& text) {
  try {
    ParseResultJson(text, "out/result.json");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    EXPECT_FALSE(e.problem().empty());
    return e.what();
  }
  return "";
}
std::string Refusal(const json& doc) { return RefusalOfText(doc.dump()); }

TEST(ResultReader, ReadsRealDocuments) {
  for (const char* name : {"cylinder-1080r.json", "uncorrected-nofit.json", "rejected-photos-nofit.json"}) {
    SCOPED_TRACE(name);
    const json j = ReadResultJson(Corpus(name));
    EXPECT_EQ(j["format"], "curvecheck.result/1");
    EXPECT_FALSE(j["features"].empty());
  }
  const json j = ReadResultJson(Corpus("cylinder-1080r.json"));
  EXPECT_EQ(j["fit"]["model"], "cylinder");
  EXPECT_NEAR(j["fit"]["radius_mm"].get<double>(), 1071.6, 0.1);
  EXPECT_TRUE(ReadResultJson(Corpus("uncorrected-nofit.json"))["fit"]["model"].is_null());
  // A real document edited into the shape of an ill-conditioned fit.
  EXPECT_TRUE(ReadResultJson(Corpus("edited-ill-conditioned.json"))["fit"]["radius_mm"].is_null());
}

TEST(ResultReader, AcceptsNullsWhereTheFitMayHaveNoNumberAndFitWarnings) {
  json j = Good();
  j["fit"]["radius_mm"] = nullptr;
  j["fit"]["radius_sigma_mm"] = nullptr;
  j["fit"]["radius_ci95_mm"] = {nullptr, nullptr};
  j["fit"]["warnings"] = {"radius ill-conditioned: the photo covers 20% of the width"};
  j["fit"]["candidates"][1]["condition_note"] = "radius unobservable";
  EXPECT_EQ(Refusal(j), "");
}

TEST(ResultReader, NamesTheFileAndTheKeyOfAWrongType) {
  json j = Good();
  j["fit"]["candidates"][2]["radius_mm"] = "1000";
  EXPECT_EQ(Refusal(j),
            "out/result.json: key 'fit.candidates[2].radius_mm' is a string, not a number or null; the file was not "
            "written by this version of curvecheck analyze or was edited; re-run curvecheck analyze");
  j = Good();
  j["verification"]["pass"] = 1;
  EXPECT_THAT(Refusal(j), HasSubstr("key 'verification.pass' is a number, not true or false"));
  j = Good();
  j["features"][3]["detected_px"] = {1, 2, 3};
  EXPECT_THAT(Refusal(j), HasSubstr("key 'features[3].detected_px' is a list of 3, not a list of 2 numbers"));
  j = Good();
  j["fit"]["warnings"] = {"ok", 7};
  EXPECT_THAT(Refusal(j), HasSubstr("key 'fit.warnings[1]' is a number, not a string"));
  j = Good();
  j["inputs"]["photos"][0]["status"] = "maybe";
  EXPECT_THAT(Refusal(j), HasSubstr("key 'inputs.photos[0].status' is \"maybe\", not \"used\" or \"rejected\""));
}

TEST(ResultReader, RefusesMissingKeysAndOtherFormats) {
  json j = Good();
  j.erase("features");
  EXPECT_THAT(Refusal(j), HasSubstr("key 'features' is missing"));
  j = Good();
  j["fit"]["candidates"][0].erase("radius_ci95_mm");
  EXPECT_THAT(Refusal(j), HasSubstr("key 'fit.candidates[0].radius_ci95_mm' is missing"));
  j = Good();
  j["format"] = "curvecheck.pattern/1";
  EXPECT_EQ(Refusal(j), "out/result.json: key 'format' is \"curvecheck.pattern/1\", not \"curvecheck.result/1\"; "
                        "this version reads curvecheck.result/1 files written by curvecheck analyze");
  EXPECT_THAT(Refusal(json::array({1, 2})), HasSubstr("key '(top level)' is a list, not an object"));
}

TEST(ResultReader, RefusesInconsistentDocuments) {
  json j = Good();
  j["deviations"]["map"]["mm"] = {1, 2, 3, 4, 5};
  EXPECT_THAT(Refusal(j), HasSubstr("key 'deviations.map.mm' has 5 values, not nu x nv = 533"));
  j = Good();
  j["features"][0]["photo"] = "someone-else.png";
  EXPECT_THAT(Refusal(j), HasSubstr("key 'features[0].photo' is 'someone-else.png', not the name of a used photo"));
  j = Good();
  j["inputs"]["photos"].push_back(j["inputs"]["photos"][0]);
  EXPECT_THAT(Refusal(j), HasSubstr("key 'inputs.photos[1].name' 'photo-exact.png' appears twice"));
  j = Good();
  j["inputs"]["photos"][0]["name"] = "../x.png";
  EXPECT_THAT(Refusal(j), HasSubstr("key 'inputs.photos[0].name' must be a file name"));
  j = Good();
  j["deviations"]["map"]["nu"] = 2000000;
  EXPECT_THAT(Refusal(j), HasSubstr("key 'deviations.map.nu' is 2000000, outside 1 .. 1000000"));
}

TEST(ResultReader, RefusesTextThatIsNotAFiniteShallowJsonDocument) {
  EXPECT_THAT(RefusalOfText("{\"format\": "), HasSubstr("out/result.json: is not valid JSON"));
  EXPECT_THAT(RefusalOfText(""), HasSubstr("is not valid JSON"));
  // Numbers beyond double: refused by the parser; non-finite numbers in a document in memory (where nlohmann::json
  // can hold them; its dump writes null): refused by the check.
  std::string text = Good().dump();
  const std::string key = "\"rms_px\":";
  const size_t at = text.rfind(key);
  ASSERT_NE(at, std::string::npos);
  text.insert(at + key.size(), "1e999,\"x\":");
  EXPECT_THAT(RefusalOfText(text), HasSubstr("is not valid JSON ([json.exception.out_of_range.406] number overflow"));
  json j = Good();
  j["verification"]["rms_px"] = std::nan("");
  try {
    CheckResultJson(j, "memory");
    ADD_FAILURE() << "NaN accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("memory: key 'verification.rms_px' is not a finite number"));
  }
  // 10000 nested lists: refused while parsing (a 20 kB file), not by overflowing the stack.
  EXPECT_THAT(RefusalOfText(std::string(10000, '[') + std::string(10000, ']')),
              HasSubstr("out/result.json: is nested more than 32 levels deep"));
}

}  // namespace
}  // namespace curvecheck
