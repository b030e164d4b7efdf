#include "experiments/shards.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <map>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck::experiments {
namespace fs = std::filesystem;

void Shard::Check() const {
  if (count < 1 || index < 1 || index > count) {
    throw Error("--shard", fmt::format("{}/{} is not i/n with 1 <= i <= n", index, count),
                "write e.g. --shard 2/4");
  }
}

Shard ParseShard(const std::string& text) {
  Shard s{0, 0};
  const size_t slash = text.find('/');
  try {
    if (slash != std::string::npos) s = {std::stoi(text.substr(0, slash)), std::stoi(text.substr(slash + 1))};
  } catch (const std::exception&) {
    s.count = 0;
  }
  if (s.count < 1 || s.index < 1 || s.index > s.count || fmt::format("{}/{}", s.index, s.count) != text) {
    throw Error("--shard", fmt::format("'{}' is not i/n with 1 <= i <= n", text), "write e.g. --shard 2/4");
  }
  return s;
}

std::vector<fs::path> ShardDirs(const std::vector<std::string>& dirs, const ShardFiles& files) {
  std::vector<fs::path> found;
  std::error_code ec;
  for (const std::string& d : dirs) {
    if (fs::exists(fs::path(d) / files.json, ec)) {
      found.emplace_back(d);
      continue;
    }
    std::vector<fs::path> sub;
    if (fs::is_directory(d, ec)) {
      for (const auto& e : fs::directory_iterator(d, ec)) {
        if (e.is_directory() && fs::exists(e.path() / files.json, ec)) sub.push_back(e.path());
      }
    }
    if (sub.empty()) {
      throw Error(d, fmt::format("holds no {}, nor do its subfolders", files.json),
                  fmt::format("give the output folders of `{}`", files.producer));
    }
    std::sort(sub.begin(), sub.end());
    found.insert(found.end(), sub.begin(), sub.end());
  }
  return found;
}

MergedShards ReadShards(const std::vector<fs::path>& dirs, const ShardFiles& files) {
  MergedShards m;
  fs::path first;
  std::map<long, fs::path> owner;
  for (const fs::path& d : dirs) {
    const fs::path json_path = d / files.json;
    nlohmann::json meta;
    try {
      meta = nlohmann::json::parse(ReadFileToString(json_path));
    } catch (const nlohmann::json::exception& e) {
      throw Error(json_path.string(), std::string("is not valid JSON: ") + e.what(),
                  fmt::format("give {} outputs, unedited", files.what));
    }
    if (!meta.is_object() || meta.value("format", "") != files.format || !meta.contains("grid")) {
      throw Error(json_path.string(), fmt::format("is not a {} file", files.format),
                  fmt::format("give the output folders of `{}`", files.producer));
    }
    if (first.empty()) {
      m.grid = meta["grid"];
      first = d;
    } else if (meta["grid"] != m.grid) {
      std::string what;
      for (const auto& [key, value] : m.grid.items()) {
        if (!meta["grid"].contains(key) || meta["grid"][key] != value) {
          what += fmt::format("{}{}: {} here, {} in {}", what.empty() ? "" : "; ", key,
                              meta["grid"].contains(key) ? meta["grid"][key].dump() : "missing", value.dump(),
                              first.string());
        }
      }
      throw Error(json_path.string(), fmt::format("is a shard of a different {} ({})", files.what, what),
                  fmt::format("merge only the shards of one {} command ({})", files.what, files.same));
    }
    const fs::path csv_path = d / files.csv;
    SweepTable t = SweepTable::FromCsv(ReadFileToString(csv_path), csv_path.string(), files.required_columns,
                                       files.producer);
    if (m.table.header.empty()) m.table.header = t.header;
    if (t.header != m.table.header) {
      throw Error(csv_path.string(), "has other columns than " + (first / files.csv).string(),
                  fmt::format("merge only the shards of one {} command", files.what));
    }
    if (!files.rows_pointer.empty()) {
      const nlohmann::json::json_pointer at(files.rows_pointer);
      if (meta.contains(at) && meta[at].is_number_unsigned() && meta[at].get<size_t>() != t.rows.size()) {
        throw Error(csv_path.string(),
                    fmt::format("holds {} rows, but {} beside it says {} (the file is cut short or was edited)",
                                t.rows.size(), files.json, meta[at].get<size_t>()),
                    fmt::format("run this shard again, or give the {} that `{}` wrote", files.csv, files.producer));
      }
    }
    for (auto& row : t.rows) {
      long index = -1;
      const auto [end, ec] = std::from_chars(row[0].data(), row[0].data() + row[0].size(), index);
      if (ec != std::errc() || end != row[0].data() + row[0].size() || index < 0) {
        throw Error(csv_path.string(), fmt::format("has the index '{}', not a whole number", row[0]),
                    fmt::format("give the {} that `{}` wrote, unedited", files.csv, files.producer));
      }
      const auto [it, inserted] = owner.emplace(index, d);
      if (!inserted) {
        throw Error(csv_path.string(),
                    fmt::format("point {} is also in {}: the shards overlap", index, it->second.string()),
                    "merge each shard once (--shard i/n with the same n, each i once)");
      }
      m.table.rows.push_back(std::move(row));
    }
    m.merged_from.push_back(d.string());
  }
  std::sort(m.table.rows.begin(), m.table.rows.end(),
            [](const auto& a, const auto& b) { return std::stol(a[0]) < std::stol(b[0]); });
  return m;
}

}  // namespace curvecheck::experiments
