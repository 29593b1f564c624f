// SIGINT / SIGTERM handling: an interrupted run never leaves a temporary file
// behind (docs/formats.md §2), and a long run can stop cleanly.
//
// Two mechanisms, both process-wide (signal dispositions belong to the process):
//
//  * TempFileGuard (used by writeArchive): while a guard is alive, SIGINT and
//    SIGTERM unlink its temporary file and end the process with _exit(130) /
//    _exit(143) (128 + signal number). The handler only calls unlink() and
//    _exit(), both async-signal-safe; the path lives in a static buffer. The
//    previous handlers are restored when the guard is destroyed. A signal that
//    was ignored (SIG_IGN, e.g. under nohup) stays ignored. One guard at a
//    time: a second guard (from another thread) waits until the first ends.
//
//  * The interrupt flag for long runs: after installInterruptFlag(), the first
//    SIGINT or SIGTERM only sets a flag that the optimizer polls through
//    interruptRequested(); it then stops and writes its archive. A second
//    signal while no write is under way ends the process at once with
//    128 + signal (nothing is being written, so nothing is left behind). During
//    a write the guard's handler is in charge: any signal removes the
//    temporary file and exits, and the flag handler is back afterwards.
#pragma once

#include <mutex>
#include <string>

namespace rodmesh {

// Installs the flag handler for SIGINT and SIGTERM (idempotent). Signals that
// are ignored when it is called stay ignored.
void installInterruptFlag();

// Restores the handlers that were in place before installInterruptFlag() and
// clears the flag. Does nothing if the flag handler is not installed.
void uninstallInterruptFlag();

// True once SIGINT or SIGTERM arrived after installInterruptFlag().
bool interruptRequested();

// The signal that set the flag (SIGINT or SIGTERM), 0 if none.
int interruptSignal();

// Clears the flag (a run that handled one interrupt may continue waiting for the next).
void clearInterruptRequest();

// See above. `path` is unlinked by the signal handler only; the owner removes
// or renames the file itself on the normal paths.
class TempFileGuard {
 public:
  explicit TempFileGuard(const std::string& path);
  ~TempFileGuard();
  TempFileGuard(const TempFileGuard&) = delete;
  TempFileGuard& operator=(const TempFileGuard&) = delete;

 private:
  std::unique_lock<std::mutex> lock_;
};

// Removes files named `path`.tmp.PID in the directory of `path` whose PID is
// not a running process (kill(PID, 0) fails with ESRCH), i.e. temporary files
// left by a writer that was killed with SIGKILL. Files of live processes (or of
// processes of other users, EPERM) and any other names are left alone. Returns
// the number of files removed; never throws.
int removeStaleTempFiles(const std::string& path);

}  // namespace rodmesh
