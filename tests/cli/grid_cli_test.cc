// End-to-end tests of `rodmesh mesh --grid` (generated sheets): the scene it
// writes satisfies the contract and simulates; usage errors exit with status
// 2, one message line and nothing written. Skipped when the executable was
// built without the meshing module (no `mesh` verb).
#include <dirent.h>
#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/archive.hh"
#include "io/scene_reader.hh"

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;

using clitest::readText;

using clitest::shellQuote;

class GridCli : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_grid_cli_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    log_ = dir_ + ".log";
    ASSERT_EQ(mkdir(log_.c_str(), 0755), 0);
    // Built only with the meshing module (tests/CMakeLists.txt).
    ASSERT_EQ(run("mesh --help"), 0) << "rodmesh has no mesh verb";
  }
  void TearDown() override { std::system(("rm -rf " + shellQuote(dir_) + " " + shellQuote(log_)).c_str()); }

  int run(const std::string& args) {
    const std::string cmd = "cd " + shellQuote(dir_) + " && " + shellQuote(kExe) + " " + args + " >" +
                            shellQuote(log_ + "/out") + " 2>" + shellQuote(log_ + "/err");
    const int raw = std::system(cmd.c_str());
    err_ = readText(log_ + "/err");
    return (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
  }
  std::vector<std::string> files() const { return clitest::listFiles(dir_); }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  std::string dir_, log_, err_;
};

TEST_F(GridCli, PaperSheetMeshesAndSimulates) {
  ASSERT_EQ(run("mesh --grid hex --size 0.2 0.2 --cells 4 5 --rod-vertices 11 --fix-side left "
                "--pull right 0.2 0 0 -o sheet.json"),
            0)
      << err_;
  const Scene s = readSceneFile(path("sheet.json"));
  EXPECT_EQ(s.vertices.size(), 693u);
  EXPECT_EQ(s.rods.size(), 71u);
  ASSERT_EQ(s.poses.size(), 1u);
  EXPECT_EQ(s.poses[0].name, "pull_right");
  EXPECT_EQ(s.poses[0].fixed.size(), 33u);  // 3 vertical rods of 11 vertices on the left
  ASSERT_EQ(run("simulate sheet.json -o sheet.h5"), 0) << err_;
  const Archive a = readArchive(path("sheet.h5"));
  EXPECT_EQ(a.status, "converged");
}

TEST_F(GridCli, EveryKindWritesAValidScene) {
  for (const char* kind : {"hex", "quad", "tri"}) {
    SCOPED_TRACE(kind);
    ASSERT_EQ(run(std::string("mesh --grid ") + kind + " --size 0.1 0.05 --cells 3 2 --rod-vertices 3 -o g.json"), 0)
        << err_;
    const Scene s = readSceneFile(path("g.json"));
    for (const Vec3& x : s.vertices) {
      EXPECT_EQ(x.z(), 0.0);
      EXPECT_LE(std::abs(x.x()), 0.05 + 1e-12);
      EXPECT_LE(std::abs(x.y()), 0.025 + 1e-12);
    }
    for (const Rod& r : s.rods) EXPECT_EQ(r.vertices.size(), 3u);
    ASSERT_EQ(run("simulate g.json -o g.h5"), 0) << err_;  // one pose, nothing held, no load
  }
}

TEST_F(GridCli, UsageErrorsExitTwoAndWriteNothing) {
  const std::vector<std::string> bad = {
      "mesh -o x.json",                                                          // neither SURFACE nor --grid
      "mesh s.obj --grid hex --size 0.2 0.2 --cells 4 5 -o x.json",              // both
      "mesh --grid hex --cells 4 5 -o x.json",                                   // no --size
      "mesh --grid hex --size 0.2 0.2 -o x.json",                                // no --cells
      "mesh --grid hex --size 0.2 0.2 --cells 4 -o x.json",                      // one count
      "mesh --grid hex --size 0.2 0.2 --cells 4 x -o x.json",                    // not a count
      "mesh --grid hexagon --size 0.2 0.2 --cells 4 5 -o x.json",                // unknown kind
      "mesh --grid quad --size 0.2 0.2 --cells 4 5 --rod-vertices 1 -o x.json",  // K < 2
      "mesh --grid quad --size 0.2 -1 --cells 4 5 -o x.json",                    // negative size
      "mesh --grid quad --size 0.2 0.2 --cells 0 5 -o x.json",                   // no cells
      "mesh --grid quad --size 0.2 0.2 --cells 4 5 --fix-side north -o x.json",  // unknown side
      "mesh --grid quad --size 0.2 0.2 --cells 4 5 --dual -o x.json",            // surface-only flag
      "mesh --grid quad --size 0.2 0.2 --cells 4 5 --fix-side right --pull right 1 0 0 -o x.json",
  };
  for (const std::string& args : bad) {
    SCOPED_TRACE(args);
    const std::vector<std::string> before = files();
    EXPECT_EQ(run(args), 2) << err_;
    EXPECT_EQ(files(), before);
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
  }
}

}  // namespace
}  // namespace rodmesh
