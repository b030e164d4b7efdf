// Output paths of commands (nothing lost: outputs never replace inputs; folders are checked before work starts).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace curvecheck::app {

// Throws Error if `output` is (the same file as) one of `inputs`.
void CheckNotAnInput(const std::filesystem::path& output, const std::vector<std::filesystem::path>& inputs);

// Creates `dir` if missing and checks that it is a folder we can write into (by creating and removing a
// probe file). Throws Error naming `option` and the folder otherwise.
void PrepareOutputDir(const std::filesystem::path& dir, const std::string& option);

}  // namespace curvecheck::app
