// Shards of a grid run and their merge (shards.h), on hand-written shard folders: the --shard parser, which
// items a shard runs, and ReadShards joining two shards and refusing mismatched or overlapping ones.
#include "experiments/shards.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(Shards, ParseShardAcceptsOnlyIOverN) {
  const Shard s = ParseShard("2/3");
  EXPECT_EQ(s.index, 2);
  EXPECT_EQ(s.count, 3);
  EXPECT_FALSE(s.Has(0));
  EXPECT_TRUE(s.Has(1));
  EXPECT_FALSE(s.Has(2));
  EXPECT_TRUE(s.Has(4));
  EXPECT_TRUE(ParseShard("1/1").Has(7));
  for (const char* bad : {"0/2", "3/2", "1/0", "a/b", "2", "1/2/3", "01/2", " 1/2", ""}) {
    try {
      ParseShard(bad);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("--shard")) << bad;
    }
  }
}

class ShardsRead : public ::testing::Test {
 protected:
  void Write(const std::string& name, const nlohmann::json& grid, const std::string& csv) {
    fs::create_directories(folder_.path() / name);
    WriteFileAtomic(folder_.path() / name / "t.json",
                    nlohmann::json{{"format", "t/1"}, {"grid", grid}}.dump());
    WriteFileAtomic(folder_.path() / name / "t.csv", csv);
  }
  fs::path Dir(const std::string& name) const { return folder_.path() / name; }
  const ShardFiles files_{"t.json", "t.csv", "t/1", "curvecheck t", "t run", "same grid", {"cell"}, ""};
  TempFolder folder_{"curvecheck_shards_test", "shards test"};
};

TEST_F(ShardsRead, JoinsShardsSortedByIndexAndRefusesMismatchesAndOverlaps) {
  Write("all/s1", {{"seed", 1}}, "index,cell\n0,a\n2,b\n");
  Write("all/s2", {{"seed", 1}}, "index,cell\n3,c\n1,d\n");
  const std::vector<fs::path> dirs = ShardDirs({Dir("all").string()}, files_);
  ASSERT_EQ(dirs.size(), 2u);
  const MergedShards m = ReadShards(dirs, files_);
  ASSERT_EQ(m.table.rows.size(), 4u);
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(m.table.rows[i][0], std::to_string(i));
  EXPECT_EQ(m.table.Str(1, "cell"), "d");
  EXPECT_EQ(m.grid, (nlohmann::json{{"seed", 1}}));
  EXPECT_EQ(m.merged_from.size(), 2u);

  Write("other", {{"seed", 2}}, "index,cell\n5,e\n");
  try {
    ReadShards({Dir("all/s1"), Dir("other")}, files_);
    ADD_FAILURE() << "merged shards of different grids";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("is a shard of a different t run (seed: 2 here, 1 in"));
  }
  try {
    ReadShards({Dir("all/s1"), Dir("all/s1")}, files_);
    ADD_FAILURE() << "merged a shard twice";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("point 0 is also in"));
  }
  Write("nocell", {{"seed", 1}}, "index,other\n4,x\n");
  EXPECT_THROW(ReadShards({Dir("nocell")}, files_), Error);
  EXPECT_THROW(ShardDirs({Dir("nowhere").string()}, files_), Error);
}

// A CSV cut short parses (a header with the required columns and no row), so the row count the JSON states is
// what tells it from a shard that ran no point; an index that is not a whole number is refused by name too.
TEST_F(ShardsRead, RefusesACsvWithOtherRowsThanItsJsonStatesAndABadIndex) {
  ShardFiles files = files_;
  files.rows_pointer = "/rows";
  const auto write = [&](const std::string& name, const std::string& csv, int rows) {
    fs::create_directories(Dir(name));
    WriteFileAtomic(Dir(name) / "t.json", nlohmann::json{{"format", "t/1"}, {"grid", {{"seed", 1}}}, {"rows", rows}}.dump());
    WriteFileAtomic(Dir(name) / "t.csv", csv);
  };
  write("cut", "index,cell,ext", 1);  // cut inside its header
  try {
    ReadShards({Dir("cut")}, files);
    ADD_FAILURE() << "merged a shard whose CSV was cut in its header";
  } catch (const Error& e) {
    EXPECT_EQ(e.where(), (Dir("cut") / "t.csv").string());
    EXPECT_THAT(e.problem(), HasSubstr("holds 0 rows, but t.json beside it says 1"));
  }
  write("whole", "index,cell\n0,a\n", 1);
  EXPECT_EQ(ReadShards({Dir("whole")}, files).table.rows.size(), 1u);
  write("empty", "index,cell\n", 0);  // a shard with no point is a shard
  EXPECT_EQ(ReadShards({Dir("empty")}, files).table.rows.size(), 0u);
  write("badindex", "index,cell\n0x1,a\n", 1);
  try {
    ReadShards({Dir("badindex")}, files);
    ADD_FAILURE() << "accepted the index 0x1";
  } catch (const Error& e) {
    EXPECT_THAT(e.problem(), HasSubstr("has the index '0x1', not a whole number"));
  }
}

}  // namespace
}  // namespace curvecheck::experiments
