#include "core/output_paths.h"

#include <fmt/format.h>
#include <unistd.h>

#include "core/error.h"

namespace curvecheck {
namespace fs = std::filesystem;

namespace {

// One spelling per file, existing or not: absolute, symlinks of the existing part resolved, "." and ".." gone.
fs::path Normal(const fs::path& p) {
  std::error_code ec;
  fs::path n = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p, ec).lexically_normal() : n;
}

bool SameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return Normal(a) == Normal(b);
}

}  // namespace

bool IsAnInput(const fs::path& output, const std::vector<fs::path>& inputs) {
  std::error_code ec;
  for (const fs::path& in : inputs) {
    if (fs::exists(in, ec) && fs::exists(output, ec) && fs::equivalent(in, output, ec)) return true;
  }
  return false;
}

void CheckNotAnInput(const fs::path& output, const std::vector<fs::path>& inputs) {
  if (IsAnInput(output, inputs)) throw Error(output.string(), "is an input of this command", "choose another output path");
}

void CheckOutputs(const std::vector<NamedOutput>& outputs, const std::vector<fs::path>& inputs) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    CheckNotAnInput(outputs[i].path, inputs);
    for (size_t j = 0; j < i; ++j) {
      if (SameFile(outputs[i].path, outputs[j].path)) {
        throw Error(outputs[i].path.string(),
                    fmt::format("is written twice: as {} and as {}", outputs[j].what, outputs[i].what),
                    "give the outputs different names");
      }
    }
  }
}

void PrepareOutputDir(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw Error(option, fmt::format("'{}' exists and is not a folder", dir.string()), "give a folder path");
  }
  fs::create_directories(dir, ec);
  if (ec) throw Error(option, fmt::format("cannot create folder '{}': {}", dir.string(), ec.message()), "");
  try {
    CheckWritable(dir / ".curvecheck-write-probe");
  } catch (const Error&) {
    throw Error(option, fmt::format("folder '{}' is not writable", dir.string()), "choose a folder you can write to");
  }
}

OutputFolder::OutputFolder(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw Error(option, fmt::format("'{}' exists and is not a folder", dir.string()), "give a folder path");
  }
  // The folders this run makes, outermost first; each registered before it is made.
  std::vector<fs::path> missing;
  for (fs::path p = fs::absolute(dir, ec).lexically_normal(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    if (p == p.parent_path()) break;
    missing.insert(missing.begin(), p);
  }
  try {
    for (const fs::path& p : missing) {
      const InterruptHold hold;
      created_.emplace_back(p, CleanupOnInterrupt(p, CleanupKind::kEmptyFolder));
      if (!fs::create_directory(p, ec) && ec) {
        throw Error(option, fmt::format("cannot create folder '{}': {}", p.string(), ec.message()),
                    "choose a folder you can write to");
      }
    }
    PrepareOutputDir(dir, option);
    lock_ = std::make_unique<FolderLock>(dir, option);
  } catch (...) {
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) ::rmdir(it->first.c_str());
    throw;
  }
}

OutputFolder::~OutputFolder() {
  lock_.reset();  // its file first: a folder left empty goes
  if (!keep_) {
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) ::rmdir(it->first.c_str());
  }
}

}  // namespace curvecheck
