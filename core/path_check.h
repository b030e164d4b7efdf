// What stands at an input path, classified without throwing. std::filesystem's throwing overloads turn a symbolic
// link loop (ELOOP) into an exception that reaches the user as an "internal error", and its non-throwing ones make
// it look like a missing file; these say what it is, in the project's one-line error form.
#pragma once

#include <filesystem>
#include <string>

namespace curvecheck {

enum class PathKind {
  kFile,         // a regular file (after following links)
  kFolder,       // a folder (after following links)
  kOther,        // exists, but is neither (a device, a FIFO, a socket)
  kMissing,      // nothing there, or a link to nothing
  kLinkLoop,     // a symbolic link that leads back to itself (ELOOP)
  kUnreachable,  // stat failed otherwise (a folder on the way not searchable, a name too long)
};

// Follows links. Never throws. `reason` (optional) receives the system's text when kUnreachable.
PathKind ClassifyPath(const std::filesystem::path& path, std::string* reason = nullptr);

// The problem part of an error about `path` being `kind` where a file or folder was wanted, e.g.
// "is a symbolic link loop", "file does not exist"; `missing` is the text used for kMissing.
std::string PathProblem(PathKind kind, const std::string& missing, const std::string& reason = "");

// Throws Error(path, problem, fix) unless `path` can be read as a file (a regular file, or a pipe or device such as
// a shell's <(...)): "file does not exist; check the path",
// "is a symbolic link loop; make the link point at the file (ls -l shows where it leads)", "is a folder, not a
// file; give a file". `fix_if_missing` replaces the fix for a missing path.
void RequireFile(const std::filesystem::path& path, const std::string& fix_if_missing = "check the path");

// The same for a folder: "is not a folder; FIX" when missing or a file, "is a symbolic link loop; ..." for a loop.
void RequireFolder(const std::filesystem::path& path, const std::string& fix);

}  // namespace curvecheck
