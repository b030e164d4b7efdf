#include "core/interrupt.h"

#include <pthread.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <utility>

namespace curvecheck {
namespace {
namespace fs = std::filesystem;

struct Registry {
  std::recursive_mutex mutex;
  std::map<uint64_t, std::pair<fs::path, CleanupKind>> paths;  // by registration order
  uint64_t next_id = 1;
  std::set<pid_t> children;
};

// Never destroyed: the signal thread may use it while static destructors run at exit.
Registry& TheRegistry() {
  static Registry* registry = new Registry;
  return *registry;
}

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

// Stops the children: SIGTERM, then SIGKILL to those still there after 2 s. A child that another thread reaps
// meanwhile shows as ECHILD, which is as good as gone.
void StopChildren(const std::set<pid_t>& children) {
  for (pid_t pid : children) ::kill(pid, SIGTERM);
  std::set<pid_t> left = children;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (!left.empty() && std::chrono::steady_clock::now() < deadline) {
    for (auto it = left.begin(); it != left.end();) {
      int status = 0;
      const pid_t r = ::waitpid(*it, &status, WNOHANG);
      it = r == 0 ? std::next(it) : left.erase(it);
    }
    if (!left.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (pid_t pid : left) {
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
  }
}

void RemovePath(const fs::path& path, CleanupKind kind) {
  std::error_code ec;
  switch (kind) {
    case CleanupKind::kFile:
      fs::remove(path, ec);
      break;
    case CleanupKind::kTree:
      // A second pass for a file a child wrote while the first one ran (the children are stopped first, so this
      // is belt and braces).
      for (int pass = 0; pass < 2 && fs::exists(fs::symlink_status(path, ec)); ++pass) fs::remove_all(path, ec);
      break;
    case CleanupKind::kEmptyFolder:
      ::rmdir(path.c_str());
      break;
  }
}

[[noreturn]] void OnInterrupt(int signal) {
  Registry& r = TheRegistry();
  r.mutex.lock();  // never given back: nothing registered is created or published after this
  StopChildren(r.children);
  for (auto it = r.paths.rbegin(); it != r.paths.rend(); ++it) RemovePath(it->second.first, it->second.second);
  // End by the signal itself (exit status 128 + N): default action, unblocked in this thread only, where the
  // pending signal is then delivered.
  struct sigaction dfl = {};
  dfl.sa_handler = SIG_DFL;
  ::sigaction(signal, &dfl, nullptr);
  sigset_t one;
  sigemptyset(&one);
  sigaddset(&one, signal);
  ::pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
  ::raise(signal);
  ::_exit(128 + signal);  // not reached
}

}  // namespace

void InstallInterruptHandling() {
  static bool installed = false;
  if (installed) return;
  installed = true;
  sigset_t set;
  sigemptyset(&set);
  for (int s : kSignals) {
    struct sigaction old = {};
    ::sigaction(s, nullptr, &old);
    if (old.sa_handler != SIG_IGN) sigaddset(&set, s);  // an ignored signal stays ignored
  }
  ::pthread_sigmask(SIG_BLOCK, &set, nullptr);
  TheRegistry();  // made before any signal can need it
  std::thread([set] {
    for (;;) {
      int signal = 0;
      if (::sigwait(&set, &signal) == 0) OnInterrupt(signal);
    }
  }).detach();
}

InterruptHold::InterruptHold() : lock_(TheRegistry().mutex) {}
InterruptHold::~InterruptHold() = default;

CleanupOnInterrupt::CleanupOnInterrupt(const fs::path& path, CleanupKind kind) {
  Registry& r = TheRegistry();
  const std::lock_guard<std::recursive_mutex> lock(r.mutex);
  id_ = r.next_id++;
  r.paths.emplace(id_, std::make_pair(fs::absolute(path), kind));
}

CleanupOnInterrupt& CleanupOnInterrupt::operator=(CleanupOnInterrupt&& other) noexcept {
  if (this != &other) {
    Release();
    id_ = std::exchange(other.id_, 0);
  }
  return *this;
}

void CleanupOnInterrupt::Release() {
  if (id_ == 0) return;
  Registry& r = TheRegistry();
  const std::lock_guard<std::recursive_mutex> lock(r.mutex);
  r.paths.erase(id_);
  id_ = 0;
}

void RegisterChildProcess(pid_t pid) {
  Registry& r = TheRegistry();
  const std::lock_guard<std::recursive_mutex> lock(r.mutex);
  r.children.insert(pid);
}

void UnregisterChildProcess(pid_t pid) {
  Registry& r = TheRegistry();
  const std::lock_guard<std::recursive_mutex> lock(r.mutex);
  r.children.erase(pid);
}

size_t RegisteredCleanupCount() {
  Registry& r = TheRegistry();
  const std::lock_guard<std::recursive_mutex> lock(r.mutex);
  return r.paths.size();
}

}  // namespace curvecheck
