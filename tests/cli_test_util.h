// Helpers shared by the end-to-end tests that run the `curvecheck` binary (tests only).
#pragma once

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

// Runs `binary args...`, capturing stdout and stderr through files in `dir`. env: "NAME=value" assignments put
// before the command through env(1) ("-u NAME" unsets); empty for none.
inline CliRun RunBinary(const std::string& binary, const std::vector<std::string>& args,
                        const std::filesystem::path& dir, const std::string& env = "") {
  std::string cmd = (env.empty() ? "" : "env " + env + " ") + Quote(binary);
  for (const auto& a : args) cmd += " " + Quote(a);
  cmd += " >" + Quote((dir / "out").string()) + " 2>" + Quote((dir / "err").string());
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  r.out = Slurp(dir / "out");
  r.err = Slurp(dir / "err");
  return r;
}

// Exit 1 with exactly one line on stderr containing every piece.
inline void ExpectOneLineFailure(const CliRun& r, const std::vector<std::string>& pieces) {
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const auto& p : pieces) EXPECT_THAT(r.err, ::testing::HasSubstr(p));
}

}  // namespace curvecheck::testing
