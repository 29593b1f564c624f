#include "io/interrupt.hh"

#include <dirent.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdlib>
#include <cstring>

namespace rodmesh {
namespace {

constexpr int kSignals[2] = {SIGINT, SIGTERM};

// Serialises guards and flag (un)installation: signal dispositions are process-wide.
std::mutex g_mutex;

// Shared with the handlers: only sig_atomic_t flags and a buffer that is
// written while g_tempArmed is 0.
volatile std::sig_atomic_t g_flag = 0;       // signal that set the interrupt flag, 0 if none
volatile std::sig_atomic_t g_tempArmed = 0;  // 1 while g_tempPath names a file to unlink
char g_tempPath[PATH_MAX + 1];

// Dispositions to restore (guarded by g_mutex).
struct sigaction g_flagPrevious[2];
bool g_flagReplaced[2] = {false, false};
bool g_flagInstalled = false;
struct sigaction g_guardPrevious[2];
bool g_guardReplaced[2] = {false, false};

extern "C" void onSignalDuringWrite(int sig) {
  if (g_tempArmed) unlink(g_tempPath);
  _exit(128 + sig);
}

extern "C" void onInterruptFlag(int sig) {
  if (g_flag != 0) {
    // Second interrupt: stop now. A write in progress has its own handler, but
    // be safe should this one run in the moment a guard is being set up.
    if (g_tempArmed) unlink(g_tempPath);
    _exit(128 + sig);
  }
  g_flag = sig;
}

bool ignored(const struct sigaction& a) { return !(a.sa_flags & SA_SIGINFO) && a.sa_handler == SIG_IGN; }

// Installs `handler` for SIGINT and SIGTERM unless the signal is ignored;
// records the previous dispositions and which ones were replaced.
void installHandlers(void (*handler)(int), int flags, struct sigaction previous[2], bool replaced[2]) {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = handler;
  sigemptyset(&sa.sa_mask);
  for (int s : kSignals) sigaddset(&sa.sa_mask, s);  // no nesting of the two
  sa.sa_flags = flags;
  for (int i = 0; i < 2; ++i) {
    replaced[i] = false;
    if (sigaction(kSignals[i], nullptr, &previous[i]) != 0 || ignored(previous[i])) continue;
    replaced[i] = sigaction(kSignals[i], &sa, nullptr) == 0;
  }
}

void restoreHandlers(const struct sigaction previous[2], bool replaced[2]) {
  for (int i = 0; i < 2; ++i) {
    if (replaced[i]) sigaction(kSignals[i], &previous[i], nullptr);
    replaced[i] = false;
  }
}

}  // namespace

void installInterruptFlag() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_flagInstalled) return;
  // SA_RESTART: the run goes on after the first signal, its system calls should too.
  installHandlers(onInterruptFlag, SA_RESTART, g_flagPrevious, g_flagReplaced);
  g_flagInstalled = true;
}

void uninstallInterruptFlag() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_flagInstalled) return;
  restoreHandlers(g_flagPrevious, g_flagReplaced);
  g_flagInstalled = false;
  g_flag = 0;
}

bool interruptRequested() { return g_flag != 0; }

int interruptSignal() { return g_flag; }

void clearInterruptRequest() { g_flag = 0; }

TempFileGuard::TempFileGuard(const std::string& path) : lock_(g_mutex) {
  g_tempArmed = 0;
  // A path too long for the buffer is not armed: the handler then only exits,
  // and removeStaleTempFiles cleans up on the next write.
  if (path.size() < sizeof g_tempPath) {
    std::memcpy(g_tempPath, path.c_str(), path.size() + 1);
    g_tempArmed = 1;
  }
  installHandlers(onSignalDuringWrite, 0, g_guardPrevious, g_guardReplaced);
}

TempFileGuard::~TempFileGuard() {
  restoreHandlers(g_guardPrevious, g_guardReplaced);
  g_tempArmed = 0;
}

int removeStaleTempFiles(const std::string& path) {
  std::string dir = ".", base = path;
  const auto slash = path.find_last_of('/');
  if (slash != std::string::npos) {
    dir = slash == 0 ? "/" : path.substr(0, slash);
    base = path.substr(slash + 1);
  }
  if (base.empty()) return 0;
  const std::string prefix = base + ".tmp.";
  const std::string dirPrefix = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  int removed = 0;
  DIR* d = opendir(dir.c_str());
  if (!d) return 0;
  while (const dirent* e = readdir(d)) {
    const std::string name = e->d_name;
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.size() > 10 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const long long pid = std::strtoll(digits.c_str(), nullptr, 10);
    if (pid <= 0 || pid > INT_MAX || pid == static_cast<long long>(getpid())) continue;
    errno = 0;
    if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    if (unlink((dirPrefix + name).c_str()) == 0) ++removed;
  }
  closedir(d);
  return removed;
}

}  // namespace rodmesh
