// Interrupting rodmesh (contract §2: "an interrupted or failed run never
// leaves a partial OUT.h5"; issue 9, item 6). `simulate` and `optimize` are
// killed with SIGKILL, SIGINT and SIGTERM at several moments: as they start,
// while they solve or optimize, and while they write the archive (held open
// with the test hook RODMESH_TEST_SLOW_WRITE, io/archive.hh). After every
// kill the directory holds the inputs and the previous archive, byte for
// byte, and nothing else: no OUT.h5.tmp.PID, even after SIGKILL, because the
// archive is written into an unnamed file. The only exception is the
// contract's: the first SIGINT to `optimize` asks it to stop, and it then
// writes its best design (exit 1, a complete archive).
#include "io/archive.hh"

#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fcntl.h>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

// A long run: the cantilever's motion over 200 s in steps of at most 1 ms
// (several seconds of work), with one progress line per frame.
const std::vector<std::string> kLongSimulate = {
    "simulate", "cantilever.json", "-o", "out.h5", "--dynamic", "--duration", "90", "--max-step", "0.001"};
const std::vector<std::string> kSimulate = {"simulate", "cantilever.json", "-o", "out.h5", "-q"};
const std::vector<std::string> kOptimize = {"optimize", "optimize_small.json", "-o", "out.h5", "--method", "reduced"};

class InterruptCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_interrupt_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    log_ = dir_ + ".stderr";
    for (const char* name : {"cantilever.json", "optimize_small.json"}) {
      const std::string text = clitest::readText(kSourceDir + "/tests/cli/" + name);
      ASSERT_FALSE(text.empty()) << name;
      clitest::writeText(dir_ + "/" + name, text);
    }
    inputs_ = files();
  }
  void TearDown() override { std::system(("rm -rf " + clitest::shellQuote(dir_) + " " + log_).c_str()); }

  std::vector<std::string> files() const { return clitest::listFiles(dir_); }
  std::vector<std::string> inputsAnd(const std::string& name) const {
    std::vector<std::string> v = inputs_;
    v.push_back(name);
    std::sort(v.begin(), v.end());
    return v;
  }

  // Starts `rodmesh ARGS` in the working directory, stdout to /dev/null and
  // stderr to log_, with RODMESH_TEST_SLOW_WRITE=slowWrite when not empty.
  pid_t start(const std::vector<std::string>& args, const std::string& slowWrite = "",
              const std::string& slowHessian = "") const {
    unlink(log_.c_str());  // waitForStderr must not see the previous run's output
    const pid_t pid = fork();
    if (pid == 0) {
      if (chdir(dir_.c_str()) != 0) _exit(126);
      if (!slowWrite.empty()) setenv("RODMESH_TEST_SLOW_WRITE", slowWrite.c_str(), 1);
      if (!slowHessian.empty()) setenv("RODMESH_TEST_SLOW_HESSIAN", slowHessian.c_str(), 1);
      const int devNull = open("/dev/null", O_WRONLY);
      const int err = open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(devNull, 1);
      dup2(err, 2);
      std::signal(SIGINT, SIG_DFL);
      std::signal(SIGTERM, SIG_DFL);
      std::vector<char*> argv = {const_cast<char*>(kExe.c_str())};
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(kExe.c_str(), argv.data());
      _exit(127);
    }
    return pid;
  }

  // True once process `pid` writes its archive: it holds a non-empty unnamed
  // file (O_TMPFILE) in the working directory open, or out.h5.tmp.PID exists
  // (file systems without O_TMPFILE). Non-empty: at start-up the command
  // probes the output directory with an empty unnamed file of its own
  // (apps/cli_common.cc), which is not the archive; a signal sent then meets
  // no write guard.
  bool writing(pid_t pid) const {
    const std::string fdDir = "/proc/" + std::to_string(pid) + "/fd";
    struct stat st;
    for (const std::string& fd : clitest::listFiles(fdDir)) {
      char target[4096];
      const std::string link = fdDir + "/" + fd;
      const ssize_t n = readlink(link.c_str(), target, sizeof target - 1);
      if (n > 0 && std::string(target, n).rfind(dir_ + "/#", 0) == 0 && ::stat(link.c_str(), &st) == 0 &&
          st.st_size > 0)
        return true;
    }
    return ::stat((dir_ + "/out.h5.tmp." + std::to_string(pid)).c_str(), &st) == 0;
  }

  // Polls `ready` for up to a minute.
  template <class Ready>
  static bool waitFor(Ready ready) {
    for (int i = 0; i < 12000; ++i) {
      if (ready()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }
  bool waitForWrite(pid_t pid) const {
    return waitFor([&] { return writing(pid); });
  }
  bool waitForStderr(const std::string& text) const {
    return waitFor([&] { return clitest::readText(log_).find(text) != std::string::npos; });
  }

  // Exit status, or -SIGNAL when the process was killed by a signal.
  static int finish(pid_t pid) {
    int status = 0;
    if (waitpid(pid, &status, 0) != pid) return -1000;
    return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? -WTERMSIG(status) : -1000;
  }

  // Sends `sig` until the process ends (optimize takes the first SIGINT or
  // SIGTERM as a request to stop; a second one ends it at once). Two signals
  // sent together may arrive as one, hence the pause and the repeats, which
  // are harmless: every further signal ends the process too.
  static int signalUntilGone(pid_t pid, int sig) {
    kill(pid, sig);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (int i = 0; i < 120; ++i) {
      kill(pid, sig);
      for (int k = 0; k < 50; ++k) {
        int status = 0;
        if (waitpid(pid, &status, WNOHANG) == pid)
          return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? -WTERMSIG(status) : -1000;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    kill(pid, SIGKILL);
    return finish(pid);
  }

  // Runs the command to completion without the hook; returns its exit status.
  int runToCompletion(const std::vector<std::string>& args = kSimulate) const { return finish(start(args)); }

  // Interrupts `args` with `sig` during its write; returns the exit status.
  int interruptWrite(int sig, const std::vector<std::string>& args = kSimulate) const {
    const pid_t pid = start(args, "60");
    if (!waitForWrite(pid)) {
      kill(pid, SIGKILL);
      finish(pid);
      ADD_FAILURE() << "the write never started";
      return -1000;
    }
    kill(pid, sig);
    return finish(pid);
  }

  // Writes an archive to out.h5 and returns its bytes: the previous archive
  // that every interrupted run must leave as it is.
  std::string previousArchive() const {
    EXPECT_EQ(runToCompletion(kSimulate), 0);
    const std::string bytes = clitest::readText(dir_ + "/out.h5");
    EXPECT_FALSE(bytes.empty());
    return bytes;
  }

  // The directory holds the inputs and out.h5 with exactly `bytes`.
  void expectPreviousIntact(const std::string& bytes, const std::string& when) const {
    SCOPED_TRACE(when);
    EXPECT_EQ(files(), inputsAnd("out.h5")) << "no partial or temporary file";
    EXPECT_TRUE(clitest::readText(dir_ + "/out.h5") == bytes) << "the previous archive changed";
  }

  std::string dir_, log_;
  std::vector<std::string> inputs_;
};

TEST_F(InterruptCliTest, SigintDuringTheWriteExits130AndLeavesNothing) {
  EXPECT_EQ(interruptWrite(SIGINT), 130);
  EXPECT_EQ(files(), inputs_) << "neither out.h5 nor out.h5.tmp.*";
}

TEST_F(InterruptCliTest, SigtermDuringTheWriteExits143AndLeavesNothing) {
  EXPECT_EQ(interruptWrite(SIGTERM), 143);
  EXPECT_EQ(files(), inputs_) << "neither out.h5 nor out.h5.tmp.*";
}

TEST_F(InterruptCliTest, SigkillDuringTheWriteLeavesNothing) {
  // The archive is complete in an unnamed file: SIGKILL, which cannot be
  // caught, leaves no trace of it.
  EXPECT_EQ(interruptWrite(SIGKILL), -SIGKILL);
  EXPECT_EQ(files(), inputs_) << "neither out.h5 nor out.h5.tmp.*";
}

TEST_F(InterruptCliTest, SimulateKilledAtAnyMomentLeavesThePreviousArchiveByteForByte) {
  const std::string bytes = previousArchive();
  for (int sig : {SIGKILL, SIGINT, SIGTERM}) {
    const std::string name = strsignal(sig);
    {  // as it starts (before, during or just after reading the scene)
      const pid_t pid = start(kLongSimulate);
      kill(pid, sig);
      EXPECT_NE(finish(pid), 0);
      expectPreviousIntact(bytes, name + " at start");
    }
    {  // a few milliseconds in
      const pid_t pid = start(kLongSimulate);
      std::this_thread::sleep_for(std::chrono::milliseconds(15));
      kill(pid, sig);
      EXPECT_NE(finish(pid), 0);
      expectPreviousIntact(bytes, name + " after 15 ms");
    }
    {  // while it solves
      const pid_t pid = start(kLongSimulate);
      ASSERT_TRUE(waitForStderr("frame 10,")) << clitest::readText(log_);
      kill(pid, sig);
      EXPECT_NE(finish(pid), 0);
      expectPreviousIntact(bytes, name + " while solving");
    }
    // while it writes
    EXPECT_NE(interruptWrite(sig), 0);
    expectPreviousIntact(bytes, name + " while writing");
  }
}

TEST_F(InterruptCliTest, OptimizeKilledAtAnyMomentLeavesThePreviousArchiveByteForByte) {
  const std::string bytes = previousArchive();
  for (int sig : {SIGKILL, SIGINT, SIGTERM}) {
    const std::string name = strsignal(sig);
    {
      const pid_t pid = start(kOptimize);
      kill(pid, sig);
      EXPECT_NE(finish(pid), 0);
      expectPreviousIntact(bytes, name + " at start");
    }
    {  // while it optimizes; SIGINT and SIGTERM: a second signal before or
       // during the final write (held open by the hook) ends the run
      const pid_t pid = start(kOptimize, "60");
      ASSERT_TRUE(waitForStderr("iter    1")) << clitest::readText(log_);
      const int status = sig == SIGKILL ? (kill(pid, sig), finish(pid)) : signalUntilGone(pid, sig);
      EXPECT_EQ(status, sig == SIGKILL ? -SIGKILL : 128 + sig);
      expectPreviousIntact(bytes, name + " while optimizing");
    }
    EXPECT_EQ(interruptWrite(sig, kOptimize), sig == SIGKILL ? -SIGKILL : 128 + sig);
    expectPreviousIntact(bytes, name + " while writing");
  }
}

TEST_F(InterruptCliTest, OneSigintStopsOptimizeWhichReplacesThePreviousArchiveWithACompleteOne) {
  const std::string bytes = previousArchive();
  const pid_t pid = start(kOptimize);
  ASSERT_TRUE(waitForStderr("iter    1")) << clitest::readText(log_);
  kill(pid, SIGINT);
  EXPECT_EQ(finish(pid), 1) << clitest::readText(log_);
  EXPECT_EQ(files(), inputsAnd("out.h5"));
  EXPECT_FALSE(clitest::readText(dir_ + "/out.h5") == bytes);
  const Archive a = readArchive(dir_ + "/out.h5");
  EXPECT_EQ(a.command, "optimize");
  EXPECT_EQ(a.status, "not_converged");
  ASSERT_TRUE(a.history.has_value());
  EXPECT_FALSE(a.history->iteration.empty());
}

// Reaps a child that exits at once: its PID belongs to no process.
pid_t deadPid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  int status = 0;
  waitpid(pid, &status, 0);
  return pid;
}

TEST_F(InterruptCliTest, TheNextRunRemovesTemporaryFilesOfDeadWritersOnly) {
  // Left by a writer killed in the moment between naming its file and the
  // rename (or on a file system without O_TMPFILE)...
  const std::string stale = "out.h5.tmp." + std::to_string(deadPid());
  // ...beside one of a process that is alive (this test) and one of another archive.
  const std::string live = "out.h5.tmp." + std::to_string(getpid());
  const std::string other = "other.h5.tmp." + std::to_string(deadPid());
  for (const std::string& f : {stale, live, other}) clitest::writeText(dir_ + "/" + f, "partial");
  ASSERT_EQ(runToCompletion(), 0);
  std::vector<std::string> expected = inputsAnd("out.h5");
  expected.push_back(other);
  expected.push_back(live);
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(files(), expected);
  EXPECT_NO_THROW(readArchive(dir_ + "/out.h5"));
}

#ifdef RODMESH_HAVE_NLP
// The watchdog of `optimize` (apps/cmd_optimize.cc): a run stuck inside one
// computation that cannot finish in time (RODMESH_TEST_SLOW_HESSIAN=60 makes
// every Hessian evaluation after the first take a minute, as a MUMPS
// factorization running away would) still answers --time-limit and the first
// SIGINT or SIGTERM within 5 s, with an archive of the best design confirmed
// so far that says why it stopped.
class WatchdogCliTest : public InterruptCliTest {
 protected:
  using Clock = std::chrono::steady_clock;
  static double seconds(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
  void expectWatchdogArchive(const std::string& why) {
    EXPECT_EQ(files(), inputsAnd("out.h5"));
    const Archive a = readArchive(dir_ + "/out.h5");
    EXPECT_EQ(a.command, "optimize");
    EXPECT_EQ(a.status, "not_converged");
    ASSERT_TRUE(a.optimize.has_value());
    EXPECT_NE(a.optimize->message.find(why), std::string::npos) << a.optimize->message;
    EXPECT_NE(a.optimize->message.find("did not stop within"), std::string::npos) << a.optimize->message;
    ASSERT_TRUE(a.history.has_value());
    EXPECT_FALSE(a.history->iteration.empty());
    // The objective evaluations of the iterations it had made (the first
    // Hessian, at least, was evaluated at an evaluated point).
    EXPECT_GT(a.optimize->evaluations, 0);
    ASSERT_EQ(a.poses.size(), 2u);
    for (const ArchivePose& p : a.poses) {
      EXPECT_EQ(p.status, "converged") << "the archived design was re-solved from rest";
      EXPECT_EQ(p.initialPositions.rows(), p.positions.rows());
    }
  }
};

TEST_F(WatchdogCliTest, TimeLimitIsKeptWhileOneComputationRunsForAMinute) {
  const auto t0 = Clock::now();
  const pid_t pid = start({"optimize", "optimize_small.json", "-o", "out.h5", "--time-limit", "2"}, "", "60");
  const int status = finish(pid);
  const double took = seconds(t0);
  EXPECT_EQ(status, 1) << clitest::readText(log_);
  EXPECT_LT(took, 2.0 + 5.0) << "answered " << took - 2.0 << " s after the limit";
  expectWatchdogArchive("time limit reached");
}

TEST_F(WatchdogCliTest, FirstSigintIsAnsweredWithin5sWhileOneComputationRunsForAMinute) {
  const pid_t pid = start({"optimize", "optimize_small.json", "-o", "out.h5"}, "", "60");
  // Ipopt's first iteration is printed before its Hessian, the first slow
  // one. SAND's first phase starts with BFGS iterations (equilibria: dual
  // infeasibility 0 on their progress lines); Ipopt's lines carry its own.
  ASSERT_TRUE(waitFor([&] {
    std::istringstream lines(clitest::readText(log_));
    for (std::string line; std::getline(lines, line);)
      if (line.rfind("iter", 0) == 0 && line.find("dual inf") != std::string::npos &&
          line.find("dual inf 0.00e+00") == std::string::npos)
        return true;
    return false;
  })) << clitest::readText(log_);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto t0 = Clock::now();
  kill(pid, SIGINT);
  const int status = finish(pid);
  const double took = seconds(t0);
  EXPECT_EQ(status, 1) << clitest::readText(log_);
  EXPECT_LT(took, 5.0);
  expectWatchdogArchive("interrupted (SIGINT)");
}
#endif

}  // namespace
}  // namespace rodmesh
