// Shards of a seeded grid run and their merge, shared by `curvecheck sweep` (sweep.h) and `curvecheck bench
// validity` (bench_validity.h). A run of n shards computes, in shard i, the grid's items k with k mod n = i -
// 1; each item's seed depends on k alone, so the shards' rows are exactly the rows of an unsharded run. Each
// shard folder holds a JSON file (format and "grid": what must be equal for shards of one run) and a CSV
// table whose first column is the item index; the merge joins the tables and refuses shards of different
// grids or that overlap.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "experiments/sweep_table.h"

namespace curvecheck::experiments {

// Shard i of n (1 <= i <= n).
struct Shard {
  int index = 1, count = 1;

  bool Has(long item) const { return item % count == index - 1; }  // item k >= 0 of the grid
  // Throws Error naming --shard unless 1 <= index <= count.
  void Check() const;
};

// Parses "i/n" (the --shard option). Throws Error naming --shard for anything else.
Shard ParseShard(const std::string& text);

// What a command's shard folder holds.
struct ShardFiles {
  std::string json;      // "sweep.json": format and "grid"
  std::string csv;       // "sweep.csv": the rows, first column "index"
  std::string format;    // "curvecheck.sweep/1"
  std::string producer;  // "curvecheck sweep", for messages
  std::string what;      // "sweep": "a shard of a different sweep"
  std::string same;  // what must be equal, for the fix: "same factors, methods, scene, scale, seed, models"
  std::vector<std::string> required_columns;  // of the CSV besides "index" (SweepTable::FromCsv)
  // JSON pointer to the JSON's count of the CSV's rows ("/rows"); "" or absent from a file: not checked. A CSV
  // cut short (inside its header, say) still parses; this count is what tells it from a shard with no points.
  std::string rows_pointer;
};

// The folders to merge: each given folder with files.json, or, for a folder without one, its subfolders that
// have one (sorted). Throws Error for a folder that has neither.
std::vector<std::filesystem::path> ShardDirs(const std::vector<std::string>& dirs, const ShardFiles& files);

struct MergedShards {
  nlohmann::json grid;                                   // the shards' common "grid"
  SweepTable table;                                      // every shard's rows, sorted by index
  nlohmann::json merged_from = nlohmann::json::array();  // the folders
};

// Reads the shards in `dirs` (ShardDirs). Throws Error naming the file for unreadable JSON or CSV, a JSON of
// another format, shards of a different grid (the differing keys named), other columns, a CSV with another
// number of rows than its JSON states (files.rows_pointer), a row whose index is not a whole number, or
// overlapping shards (the same index twice).
MergedShards ReadShards(const std::vector<std::filesystem::path>& dirs, const ShardFiles& files);

}  // namespace curvecheck::experiments
