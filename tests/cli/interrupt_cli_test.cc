// Interrupting rodmesh while it writes its archive (contract §2: "an
// interrupted or failed run never leaves a partial OUT.h5"): SIGINT and
// SIGTERM during the write remove the temporary file and exit with 130 / 143;
// a temporary file left by a writer killed with SIGKILL is removed by the next
// write to the same archive. The write is held open with the test hook
// RODMESH_TEST_SLOW_WRITE (io/archive.hh), so that the signal certainly
// arrives while the temporary file exists.
#include "io/archive.hh"

#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fcntl.h>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

class InterruptCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_interrupt_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    const std::string text = clitest::readText(kSourceDir + "/tests/cli/cantilever.json");
    ASSERT_FALSE(text.empty());
    clitest::writeText(dir_ + "/cantilever.json", text);
  }
  void TearDown() override { std::system(("rm -rf " + clitest::shellQuote(dir_)).c_str()); }

  std::vector<std::string> files() const { return clitest::listFiles(dir_); }

  // Starts `rodmesh simulate cantilever.json -o out.h5 -q` in the working
  // directory, with RODMESH_TEST_SLOW_WRITE=slowWrite when not empty.
  pid_t start(const std::string& slowWrite) const {
    const pid_t pid = fork();
    if (pid == 0) {
      if (chdir(dir_.c_str()) != 0) _exit(126);
      if (!slowWrite.empty()) setenv("RODMESH_TEST_SLOW_WRITE", slowWrite.c_str(), 1);
      const int devNull = open("/dev/null", O_WRONLY);
      dup2(devNull, 1);
      dup2(devNull, 2);
      std::signal(SIGINT, SIG_DFL);
      std::signal(SIGTERM, SIG_DFL);
      execl(kExe.c_str(), kExe.c_str(), "simulate", "cantilever.json", "-o", "out.h5", "-q", (char*)nullptr);
      _exit(127);
    }
    return pid;
  }

  // Waits (up to a minute) until out.h5.tmp.PID of process `pid` exists.
  bool waitForTempFile(pid_t pid) const {
    const std::string tmp = "out.h5.tmp." + std::to_string(pid);
    for (int i = 0; i < 12000; ++i) {
      for (const std::string& f : files())
        if (f == tmp) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

  // Exit status, or -SIGNAL when the process was killed by a signal.
  static int finish(pid_t pid) {
    int status = 0;
    if (waitpid(pid, &status, 0) != pid) return -1000;
    return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? -WTERMSIG(status) : -1000;
  }

  // Runs the command to completion without the hook; returns its exit status.
  int runToCompletion() const { return finish(start("")); }

  // Interrupts a run with `sig` during its write; returns the exit status.
  int interruptWrite(int sig) const {
    const pid_t pid = start("60");
    if (!waitForTempFile(pid)) {
      kill(pid, SIGKILL);
      finish(pid);
      ADD_FAILURE() << "the temporary file never appeared";
      return -1000;
    }
    kill(pid, sig);
    return finish(pid);
  }

  std::string dir_;
};

TEST_F(InterruptCliTest, SigintDuringTheWriteExits130AndLeavesNothing) {
  EXPECT_EQ(interruptWrite(SIGINT), 130);
  EXPECT_EQ(files(), std::vector<std::string>{"cantilever.json"}) << "neither out.h5 nor out.h5.tmp.*";
}

TEST_F(InterruptCliTest, SigtermDuringTheWriteExits143AndLeavesNothing) {
  EXPECT_EQ(interruptWrite(SIGTERM), 143);
  EXPECT_EQ(files(), std::vector<std::string>{"cantilever.json"}) << "neither out.h5 nor out.h5.tmp.*";
}

TEST_F(InterruptCliTest, AnInterruptedRunKeepsThePreviousArchive) {
  ASSERT_EQ(runToCompletion(), 0);
  const Archive before = readArchive(dir_ + "/out.h5");
  EXPECT_EQ(interruptWrite(SIGINT), 130);
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));
  const Archive after = readArchive(dir_ + "/out.h5");
  ASSERT_EQ(after.poses.size(), before.poses.size());
  EXPECT_EQ(after.poses[0].positions, before.poses[0].positions);
}

TEST_F(InterruptCliTest, TheNextRunRemovesTheTemporaryFileOfAKilledWriter) {
  // SIGKILL cannot be caught: the temporary file stays behind...
  const pid_t killed = start("60");
  ASSERT_TRUE(waitForTempFile(killed));
  kill(killed, SIGKILL);
  EXPECT_EQ(finish(killed), -SIGKILL);
  const std::string stale = "out.h5.tmp." + std::to_string(killed);
  ASSERT_EQ(files(), (std::vector<std::string>{"cantilever.json", stale}));
  // ...beside one of a process that is alive (this test) and one of another archive.
  const std::string live = "out.h5.tmp." + std::to_string(getpid());
  const std::string other = "other.h5.tmp." + std::to_string(killed);
  clitest::writeText(dir_ + "/" + live, "partial");
  clitest::writeText(dir_ + "/" + other, "partial");
  // The next write to out.h5 removes the dead writer's file only.
  ASSERT_EQ(runToCompletion(), 0);
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", other, "out.h5", live}));
  EXPECT_NO_THROW(readArchive(dir_ + "/out.h5"));
}

}  // namespace
}  // namespace rodmesh
