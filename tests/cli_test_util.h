// Helpers shared by the end-to-end tests that run the `curvecheck` binary (tests only).
#pragma once

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/subprocess.h"

namespace curvecheck::testing {

struct CliRun {
  int code = -1;
  std::string out, err;
};

inline std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Single-quotes a word for /bin/sh.
inline std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `binary args...` (core/subprocess.h: an argv, no shell), capturing stdout and stderr. env: "NAME=value"
// words put before the command through env(1) ("-u NAME" unsets); empty for none. `dir` is unused (kept so that
// the callers name their folder). code: the exit status, 128 + N when killed by signal N.
inline CliRun RunBinary(const std::string& binary, const std::vector<std::string>& args,
                        const std::filesystem::path& /*dir*/, const std::string& env = "") {
  std::vector<std::string> argv;
  if (!env.empty()) {
    argv.push_back("env");
    std::istringstream words(env);
    for (std::string w; words >> w;) argv.push_back(w);
  }
  argv.push_back(binary);
  argv.insert(argv.end(), args.begin(), args.end());
  ProcessResult p = RunProcess(argv);
  return CliRun{p.status, std::move(p.stdout_text), std::move(p.stderr_text)};
}

// Exit 1 with exactly one line on stderr containing every piece.
inline void ExpectOneLineFailure(const CliRun& r, const std::vector<std::string>& pieces) {
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const auto& p : pieces) EXPECT_THAT(r.err, ::testing::HasSubstr(p));
}

// Fails the test (fatally) unless `path` is a readable regular file: an input that the project installs itself
// (a Debian package of scripts/debian-packages.txt) or generates is required, and its absence is a broken set-up,
// never a skip (ctest counts skipped tests as passed). One line: the file, the problem, the fix.
inline void RequireInstalledFile(const std::filesystem::path& path, const std::string& debian_package) {
  std::error_code ec;
  const bool file = std::filesystem::is_regular_file(path, ec);
  const bool readable = file && std::ifstream(path).good();
  ASSERT_TRUE(readable) << path.string() << ": " << (file ? "cannot be read" : "is missing")
                        << "; it comes with the Debian package " << debian_package
                        << " (scripts/debian-packages.txt): run ./bootstrap, or apt-get install " << debian_package;
}

// This test process's folder: <gtest temp dir>/<name>-<pid>, plus "-<running test's name>" when per_test. ctest runs
// each test in a process of its own, in parallel, so the pid keeps them apart. Only the path; see FreshDir.
inline std::filesystem::path ProcessDir(const std::string& name, bool per_test = false) {
  std::string leaf = name + "-" + std::to_string(::getpid());
  if (per_test) leaf += std::string("-") + ::testing::UnitTest::GetInstance()->current_test_info()->name();
  return std::filesystem::path(::testing::TempDir()) / leaf;
}

// ProcessDir(name, per_test), emptied (or created) first.
inline std::filesystem::path FreshDir(const std::string& name, bool per_test = false) {
  const std::filesystem::path d = ProcessDir(name, per_test);
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// A CSV file written by curvecheck (no quoted cells) as rows of column name -> cell; a row of another length than
// the header fails the test.
using Rows = std::vector<std::map<std::string, std::string>>;

inline Rows ReadCsv(const std::filesystem::path& p) {
  std::istringstream in(Slurp(p));
  std::string line;
  std::vector<std::string> header;
  Rows rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    if (header.empty()) {
      header = cells;
      continue;
    }
    EXPECT_EQ(cells.size(), header.size()) << line;
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

// The row without its wall-time columns (*_ms), which differ between runs.
inline std::map<std::string, std::string> WithoutTimes(std::map<std::string, std::string> row) {
  for (auto it = row.begin(); it != row.end();) {
    it = it->first.ends_with("_ms") ? row.erase(it) : std::next(it);
  }
  return row;
}

#ifdef CURVECHECK_BINARY
// Base of the fixtures whose every test has a fresh folder of its own (dir_, removed after the test) and runs the
// built `curvecheck` there. Subclasses that override SetUp/TearDown call these first/last.
class CliTest : public ::testing::Test {
 protected:
  explicit CliTest(std::string name) : name_(std::move(name)) {}
  void SetUp() override { dir_ = FreshDir(name_, true); }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  // `curvecheck args...`; env as for RunBinary.
  CliRun Curvecheck(const std::vector<std::string>& args, const std::string& env = "") {
    return RunBinary(CURVECHECK_BINARY, args, dir_, env);
  }
  void ExpectFailure(const CliRun& r, const std::vector<std::string>& pieces) { ExpectOneLineFailure(r, pieces); }

  std::filesystem::path dir_;

 private:
  std::string name_;
};
#endif

}  // namespace curvecheck::testing
