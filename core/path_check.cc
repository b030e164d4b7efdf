#include "core/path_check.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "core/error.h"

namespace curvecheck {
namespace {
constexpr const char* kLoopFix = "make the link point at an existing file or folder (ls -l shows where it leads)";
}  // namespace

PathKind ClassifyPath(const std::filesystem::path& path, std::string* reason) {
  // stat(2) directly: its errno tells a loop (ELOOP) from a missing path (ENOENT, ENOTDIR), which
  // std::filesystem::status folds into file_type::not_found / an exception.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    if (err == ELOOP) return PathKind::kLinkLoop;
    if (err == ENOENT || err == ENOTDIR) return PathKind::kMissing;
    if (reason != nullptr) *reason = std::strerror(err);
    return PathKind::kUnreachable;
  }
  if (S_ISREG(st.st_mode)) return PathKind::kFile;
  if (S_ISDIR(st.st_mode)) return PathKind::kFolder;
  return PathKind::kOther;
}

std::string PathProblem(PathKind kind, const std::string& missing, const std::string& reason) {
  switch (kind) {
    case PathKind::kFile: return "is a file";
    case PathKind::kFolder: return "is a folder, not a file";
    case PathKind::kOther: return "is not a regular file (a device, pipe or socket)";
    case PathKind::kMissing: return missing;
    case PathKind::kLinkLoop: return "is a symbolic link loop";
    case PathKind::kUnreachable: return "cannot be reached: " + reason;
  }
  return missing;
}

void RequireFile(const std::filesystem::path& path, const std::string& fix_if_missing) {
  std::string reason;
  const PathKind kind = ClassifyPath(path, &reason);
  switch (kind) {
    case PathKind::kFile:
    case PathKind::kOther: return;  // a pipe (a shell's <(...)) or a device reads as a file
    case PathKind::kMissing: throw Error(path.string(), "file does not exist", fix_if_missing);
    case PathKind::kLinkLoop: throw Error(path.string(), PathProblem(kind, ""), kLoopFix);
    case PathKind::kFolder: throw Error(path.string(), PathProblem(kind, ""), "give a file");
    case PathKind::kUnreachable: throw Error(path.string(), PathProblem(kind, "", reason), "check the permissions");
  }
}

void RequireFolder(const std::filesystem::path& path, const std::string& fix) {
  std::string reason;
  const PathKind kind = ClassifyPath(path, &reason);
  if (kind == PathKind::kFolder) return;
  if (kind == PathKind::kLinkLoop) throw Error(path.string(), PathProblem(kind, ""), kLoopFix);
  if (kind == PathKind::kUnreachable) throw Error(path.string(), PathProblem(kind, "", reason), "check the permissions");
  throw Error(path.string(), "is not a folder", fix);
}

}  // namespace curvecheck
