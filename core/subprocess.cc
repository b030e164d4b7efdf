#include "core/subprocess.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <utility>

#include "core/error.h"
#include "core/interrupt.h"

namespace curvecheck {

ChildProcess ChildProcess::Start(const std::vector<std::string>& argv, const std::filesystem::path& cwd) {
  if (argv.empty() || argv[0].empty()) throw Error("subprocess", "no program to run", "this is a bug");
  // Everything the child needs is prepared before fork: after it, only async-signal-safe calls.
  std::vector<std::string> args = argv;
  std::vector<char*> c_argv;
  for (std::string& a : args) c_argv.push_back(a.data());
  c_argv.push_back(nullptr);
  const std::string dir = cwd.string();
  int out[2], err[2];
  if (::pipe2(out, O_CLOEXEC) != 0) throw Error(argv[0], "cannot create a pipe", "check the process's file limit");
  if (::pipe2(err, O_CLOEXEC) != 0) {
    ::close(out[0]);
    ::close(out[1]);
    throw Error(argv[0], "cannot create a pipe", "check the process's file limit");
  }
  // Forked and registered under one hold: an interruption stops every child it could see started.
  const InterruptHold hold;
  const pid_t pid = ::fork();
  if (pid < 0) {
    for (int fd : {out[0], out[1], err[0], err[1]}) ::close(fd);
    throw Error(argv[0], "cannot start a process (fork failed)", "free some memory or processes");
  }
  if (pid == 0) {
    // The parent blocks the interrupting signals in every thread (core/interrupt.h); the program must not inherit
    // that, or SIGTERM would not stop it.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    ::dup2(out[1], STDOUT_FILENO);
    ::dup2(err[1], STDERR_FILENO);
    if (!dir.empty() && ::chdir(dir.c_str()) != 0) ::_exit(127);
    ::execvp(c_argv[0], c_argv.data());
    ::_exit(127);
  }
  RegisterChildProcess(pid);
  ::close(out[1]);
  ::close(err[1]);
  ChildProcess child;
  child.pid_ = pid;
  child.out_fd_ = out[0];
  child.err_fd_ = err[0];
  return child;
}

ChildProcess::ChildProcess(ChildProcess&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)),
      out_fd_(std::exchange(other.out_fd_, -1)),
      err_fd_(std::exchange(other.err_fd_, -1)) {}

ChildProcess& ChildProcess::operator=(ChildProcess&& other) noexcept {
  if (this != &other) {
    Release();
    pid_ = std::exchange(other.pid_, -1);
    out_fd_ = std::exchange(other.out_fd_, -1);
    err_fd_ = std::exchange(other.err_fd_, -1);
  }
  return *this;
}

ChildProcess::~ChildProcess() { Release(); }

void ChildProcess::Release() {
  if (pid_ > 0) {
    ::kill(pid_, SIGTERM);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    UnregisterChildProcess(pid_);
    pid_ = -1;
  }
  if (out_fd_ >= 0) ::close(out_fd_);
  if (err_fd_ >= 0) ::close(err_fd_);
  out_fd_ = err_fd_ = -1;
}

void ChildProcess::Signal(int signal) const {
  if (pid_ > 0) ::kill(pid_, signal);
}

int ChildProcess::Wait() {
  if (pid_ <= 0) return 127;
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0) {
    if (errno != EINTR) {
      UnregisterChildProcess(pid_);
      pid_ = -1;
      return 127;
    }
  }
  UnregisterChildProcess(pid_);
  pid_ = -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 128;
}

std::optional<int> ChildProcess::TryWait() {
  if (pid_ <= 0) return 127;
  int status = 0;
  const pid_t r = ::waitpid(pid_, &status, WNOHANG);
  if (r == 0 || (r < 0 && errno == EINTR)) return std::nullopt;
  UnregisterChildProcess(pid_);
  pid_ = -1;
  if (r < 0) return 127;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 128;
}

std::string ProcessResult::LastLine() const {
  const std::string& text = stderr_text.find_first_not_of(" \n\r\t") != std::string::npos ? stderr_text : stdout_text;
  size_t end = text.find_last_not_of(" \n\r\t");
  if (end == std::string::npos) return "";
  const size_t start = text.rfind('\n', end);
  return text.substr(start == std::string::npos ? 0 : start + 1, end - (start == std::string::npos ? 0 : start + 1) + 1);
}

ProcessResult RunProcess(const std::vector<std::string>& argv, const std::filesystem::path& cwd) {
  ChildProcess child = ChildProcess::Start(argv, cwd);
  ProcessResult result;
  pollfd fds[2] = {{child.stdout_fd(), POLLIN, 0}, {child.stderr_fd(), POLLIN, 0}};
  std::string* sinks[2] = {&result.stdout_text, &result.stderr_text};
  int open = 2;
  char buffer[65536];
  std::optional<int> status;
  // Until both pipes end, or the program has exited and its pipes are drained: a grandchild that inherited them
  // (a browser's helper processes) may hold them open after the program itself is gone.
  while (open > 0) {
    const int ready = ::poll(fds, 2, status ? 0 : 100);
    if (ready < 0 && errno != EINTR) break;
    if (ready == 0) {
      if (status) break;  // exited, and nothing more to read
      status = child.TryWait();
      continue;
    }
    for (int i = 0; i < 2 && ready > 0; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
      if (n > 0) {
        sinks[i]->append(buffer, static_cast<size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        fds[i].fd = -1;  // end of output (the descriptor itself is closed with the child)
        --open;
      }
    }
  }
  result.status = status ? *status : child.Wait();
  return result;
}

ProcessResult RunProcessChecked(const std::vector<std::string>& argv, const std::string& what, const std::string& fix,
                                const std::filesystem::path& cwd) {
  ProcessResult result = RunProcess(argv, cwd);
  if (result.status != 0) {
    const std::string last = result.LastLine();
    throw Error(argv[0],
                fmt::format("{} failed (exit status {}{}){}", what, result.status,
                            result.status == 127 ? ": not found or not executable" : "",
                            last.empty() ? "" : ": " + last),
                fix);
  }
  return result;
}

}  // namespace curvecheck
