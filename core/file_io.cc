#include "core/file_io.h"

#include <fcntl.h>
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

void WriteFileAtomic(const fs::path& path, std::string_view contents) {
  const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw Error(path.string(), "output folder '" + folder.string() + "' does not exist", "create it first");
  }
  std::random_device rd;
  const fs::path tmp = folder / ("." + path.filename().string() + ".tmp" + std::to_string(rd()));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw Error(path.string(), std::string("cannot write in '") + folder.string() + "': " + std::strerror(errno),
                "choose a writable output folder");
  }
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
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw Error(fs::temp_directory_path().string(), "cannot create a temporary folder for " + purpose,
                "make the temporary folder writable (or set TMPDIR)");
  }
  path_ = pattern;
}

TempFolder::~TempFolder() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

}  // namespace curvecheck
