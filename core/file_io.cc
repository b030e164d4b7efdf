#include "core/file_io.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "core/error.h"
#include "core/path_check.h"

namespace curvecheck {
namespace fs = std::filesystem;

std::string ReadFileToString(const fs::path& path) {
  RequireFile(path);  // missing, a folder, or a symbolic link loop: each said as such
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string(), std::string("cannot be opened: ") + std::strerror(errno), "check permissions");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(path.string(), "read failed", "check the disk");
  return ss.str();
}

namespace {

// Creates the temporary file beside `path` that WriteFileAtomic writes and renames (".NAME.tmpN"), registered for
// removal on interruption. Throws Error (file, reason, fix) if the folder does not exist or takes no new file.
int CreateTemporary(const fs::path& path, fs::path& tmp, CleanupOnInterrupt& cleanup) {
  const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw Error(path.string(), "output folder '" + folder.string() + "' does not exist", "create it first");
  }
  std::random_device rd;
  tmp = folder / ("." + path.filename().string() + ".tmp" + std::to_string(rd()));
  int fd = -1, err = 0;
  {
    const InterruptHold hold;  // registered and created together
    cleanup = CleanupOnInterrupt(tmp, CleanupKind::kFile);
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    err = errno;
  }
  if (fd < 0) {
    throw Error(path.string(), std::string("cannot write in '") + folder.string() + "': " + std::strerror(err),
                "choose a writable output folder");
  }
  return fd;
}

}  // namespace

void CheckWritable(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw Error(path.string(), "is a folder", "give a file path");
  fs::path tmp;
  CleanupOnInterrupt cleanup;
  const int fd = CreateTemporary(path, tmp, cleanup);
  ::close(fd);
  ::unlink(tmp.c_str());
}

void WriteFileAtomic(const fs::path& path, std::string_view contents) {
  fs::path tmp;
  CleanupOnInterrupt cleanup;
  const int fd = CreateTemporary(path, tmp, cleanup);
  auto fail = [&](const char* what) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    const bool full = err == ENOSPC || err == EDQUOT || err == EFBIG;  // EFBIG: over the file size limit (ulimit -f)
    throw Error(path.string(), std::string(what) + ": " + std::strerror(err),
                full ? "free disk space and run again" : "check the output folder");
  };
  const char* p = contents.data();
  size_t left = contents.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed");
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) fail("flush to disk failed");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path.string(), std::string("close failed: ") + std::strerror(err), "check the disk");
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path.string(), std::string("cannot replace: ") + std::strerror(err), "check the output folder");
  }
}

TempFolder::TempFolder(const std::string& prefix, const std::string& purpose) {
  std::string pattern = (fs::temp_directory_path() / (prefix + "_XXXXXX")).string();
  const InterruptHold hold;  // created and registered together
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw Error(fs::temp_directory_path().string(), "cannot create a temporary folder for " + purpose,
                "make the temporary folder writable (or set TMPDIR)");
  }
  path_ = pattern;
  purpose_ = purpose;
  cleanup_ = CleanupOnInterrupt(path_, CleanupKind::kTree);
}

fs::path TempFolder::Subfolder(const fs::path& relative) const {
  const fs::path rel = relative.lexically_normal();
  if (rel.empty() || rel == ".") return path_;
  if (rel.is_absolute() || *rel.begin() == "..") {
    throw Error(relative.string(), "is not a folder inside the temporary folder for " + purpose_, "this is a bug");
  }
  fs::path sub = path_;
  const InterruptHold hold;  // an interruption that removed path_ keeps this lock: we wait here until the exit
  // One mkdir per level, never create_directories: if path_ itself is gone it must not come back.
  for (const fs::path& part : rel) {
    if (part.empty() || part == ".") continue;
    sub /= part;
    if (::mkdir(sub.c_str(), 0700) != 0 && errno != EEXIST) {
      const int err = errno;
      throw Error(sub.string(), "cannot create a temporary folder for " + purpose_ + ": " + std::strerror(err),
                  "make the temporary folder writable (or set TMPDIR)");
    }
  }
  return sub;
}

TempFolder::~TempFolder() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

OutputSet::~OutputSet() {
  std::error_code ec;
  for (Member& m : members_) {
    if (m.cleanup.Active()) fs::remove(m.staged, ec);
  }
}

fs::path OutputSet::Stage(const fs::path& target) {
  for (const Member& m : members_) {
    if (m.target == target) return m.staged;
  }
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::random_device rd;
  const fs::path staged =
      folder / fmt::format(".{}.tmp{}{}", target.stem().string(), rd(), target.extension().string());
  // Registered now, before any writer creates it: nothing it makes there outlives an interruption.
  members_.push_back({target, staged, CleanupOnInterrupt(staged, CleanupKind::kFile)});
  return staged;
}

void OutputSet::WriteWith(const fs::path& target, const std::function<void(const fs::path&)>& write) {
  const fs::path staged = Stage(target);
  try {
    write(staged);
  } catch (const Error& e) {
    if (e.where() != staged.string()) throw;
    throw Error(target.string(), e.problem(), e.fix());
  }
}

void OutputSet::Write(const fs::path& target, std::string_view contents) {
  WriteWith(target, [&](const fs::path& staged) { WriteFileAtomic(staged, contents); });
}

void OutputSet::RemoveOnPublish(const fs::path& target) { stale_.push_back(target); }

void OutputSet::Publish() {
  const InterruptHold hold;  // the whole set or none of it
  for (Member& m : members_) {
    if (!m.cleanup.Active()) continue;
    if (::rename(m.staged.c_str(), m.target.c_str()) != 0) {
      const int err = errno;
      throw Error(m.target.string(), std::string("cannot replace: ") + std::strerror(err), "check the output folder");
    }
    m.cleanup.Release();
  }
  for (const fs::path& p : stale_) {
    bool is_member = false;
    for (const Member& m : members_) is_member = is_member || m.target == p;
    std::error_code ec;
    if (!is_member) fs::remove(p, ec);
  }
}

FolderLock::FolderLock(const fs::path& dir, const std::string& option) : path_(dir / kFileName) {
  // A lock file removed by its previous holder between our open and our flock is not the lock any more: then the
  // path names another inode (or none), and we try again. Each attempt runs inside one hold, so an interruption
  // removes the file only once it is ours.
  for (int attempt = 0; attempt < 100; ++attempt) {
    const InterruptHold hold;
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      throw Error(option, fmt::format("cannot create the lock file '{}': {}", path_.string(), std::strerror(errno)),
                  "choose a folder you can write to");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      char buffer[32] = {};
      const ssize_t n = ::pread(fd, buffer, sizeof buffer - 1, 0);
      ::close(fd);
      if (err != EWOULDBLOCK) {
        throw Error(option, fmt::format("cannot lock '{}': {}", path_.string(), std::strerror(err)),
                    "choose a folder on a local disk");
      }
      std::string pid = n > 0 ? std::string(buffer, static_cast<size_t>(n)) : std::string();
      pid = pid.substr(0, pid.find_first_of(" \n"));
      throw Error(option,
                  fmt::format("folder '{}' is in use by another curvecheck run (pid {})", dir.string(),
                              pid.empty() ? "unknown" : pid),
                  "wait for it to finish, or choose another output folder");
    }
    struct stat held = {}, named = {};
    if (::fstat(fd, &held) == 0 && ::stat(path_.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
        held.st_dev == named.st_dev) {
      cleanup_ = CleanupOnInterrupt(path_, CleanupKind::kFile);
      const std::string pid = std::to_string(::getpid()) + "\n";
      if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
        // The pid is only for a second run's message; the lock holds without it.
      }
      fd_ = fd;
      return;
    }
    ::close(fd);
  }
  throw Error(option, fmt::format("cannot lock '{}': it keeps being replaced", path_.string()),
              "make sure only curvecheck writes this folder");
}

FolderLock::~FolderLock() {
  // Removed while still held, so no other run can be holding this inode when it goes.
  ::unlink(path_.c_str());
  cleanup_.Release();
  ::close(fd_);
}

}  // namespace curvecheck
