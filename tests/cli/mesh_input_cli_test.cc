// End-to-end tests of bad input to `rodmesh mesh` and `rodmesh export`
// (issues #9 and #13): broken surface files and out-of-range numeric flags
// exit with status 2 and one message naming the file, line or flag and the
// offending value, and write nothing. Every command runs under `timeout`, so a
// hang fails the test (status 124) instead of stalling the suite. Skipped when
// the executable was built without the meshing module (no `mesh` verb).
#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;
constexpr int kTimeoutSeconds = 20;  // every command here finishes in a few seconds
constexpr int kTimedOut = 124;       // timeout(1)'s exit status (137 if it had to send KILL)

using clitest::readText;
using clitest::shellQuote;
using clitest::writeText;

class MeshInputCli : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_mesh_input_cli_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    log_ = dir_ + ".log";
    ASSERT_EQ(mkdir(log_.c_str(), 0755), 0);
    // Built only with the meshing module (tests/CMakeLists.txt): the verb must be there.
    ASSERT_EQ(run("mesh --help"), 0) << "rodmesh lacks the mesh verb";
  }
  void TearDown() override { std::system(("rm -rf " + shellQuote(dir_) + " " + shellQuote(log_)).c_str()); }

  // Runs `rodmesh ARGS` in the working directory under timeout(1); returns the
  // exit status (124 if it had to be killed), stderr in err_.
  int run(const std::string& args) {
    const std::string cmd = "cd " + shellQuote(dir_) + " && timeout -k 5 " + std::to_string(kTimeoutSeconds) + " " +
                            shellQuote(kExe) + " " + args + " >" + shellQuote(log_ + "/out") + " 2>" +
                            shellQuote(log_ + "/err");
    const int raw = std::system(cmd.c_str());
    err_ = readText(log_ + "/err");
    if (raw == -1 || !WIFEXITED(raw)) return -1;
    const int status = WEXITSTATUS(raw);
    return status == 128 + 9 ? kTimedOut : status;
  }
  std::vector<std::string> files() const { return clitest::listFiles(dir_); }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  // Expects `rodmesh ARGS` to exit 2 within the time limit with one error line
  // containing every fragment, and the directory to hold exactly `inputs`.
  void expectBadInput(const std::string& args, std::initializer_list<std::string> fragments,
                      const std::vector<std::string>& inputs) {
    SCOPED_TRACE(args);
    const int status = run(args);
    ASSERT_NE(status, kTimedOut) << "timed out after " << kTimeoutSeconds << " s";
    EXPECT_EQ(status, 2) << err_;
    EXPECT_EQ(err_.rfind("rodmesh: error: ", 0), 0u) << err_;
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << "one message line expected:\n" << err_;
    for (const std::string& f : fragments)
      EXPECT_NE(err_.find(f), std::string::npos) << "'" << f << "' not in " << err_;
    EXPECT_EQ(files(), inputs) << "something was written";
  }

  std::string dir_, log_, err_;
};

const std::string kObjTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";  // faces start on line 4

TEST_F(MeshInputCli, WrappingFaceIndicesAreExit2NamingFileLineAndValue) {
  writeText(path("wrap.obj"), kObjTriangle + "f 1 2 4294967299\n");
  expectBadInput("mesh wrap.obj -o out.json", {"wrap.obj: line 4", "'4294967299'", "out of range"}, {"wrap.obj"});
  writeText(path("wrap.off"), "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967299\n");
  expectBadInput("mesh wrap.off -o out.json", {"wrap.off: line 6", "'4294967299'", "out of range"},
                 {"wrap.obj", "wrap.off"});
  writeText(path("frac.ply"),
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar uint vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n");
  expectBadInput("mesh frac.ply -o out.json", {"frac.ply: line 13", "'2.5'", "not an integer"},
                 {"frac.ply", "wrap.obj", "wrap.off"});
}

TEST_F(MeshInputCli, BadIndicesAndCoordinatesInEveryFormat) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {kObjTriangle + "f 1 2 3abc\n", {"line 4", "'3abc'", "not an integer"}},
      {kObjTriangle + "f 1 2 1e30\n", {"line 4", "'1e30'", "not an integer"}},
      {kObjTriangle + "f 1 2 99999999999999999999\n", {"line 4", "'99999999999999999999'", "too large"}},
      {kObjTriangle + "f 1 2 -4\n", {"line 4", "'-4'"}},
      {"v 0 0 0\nv 1 0 1e999\nv 0 1 0\nf 1 2 3\n", {"line 2", "'1e999'", "overflows"}},
      {"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", {"line 2", "'nan'", "not finite"}},
  };
  for (const auto& [text, fragments] : cases) {
    writeText(path("bad.obj"), text);
    SCOPED_TRACE(text);
    const int status = run("mesh bad.obj -o out.json");
    ASSERT_NE(status, kTimedOut);
    EXPECT_EQ(status, 2) << err_;
    EXPECT_EQ(err_.find("rodmesh: error: bad.obj: "), 0u) << err_;
    for (const std::string& f : fragments)
      EXPECT_NE(err_.find(f), std::string::npos) << "'" << f << "' not in " << err_;
    EXPECT_EQ(files(), std::vector<std::string>{"bad.obj"});
  }
  // Binary PLY: the element entry instead of a line.
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  b.append(reinterpret_cast<const char*>(v), sizeof v);
  const std::uint32_t f[3] = {0, 1, 4294967295u};
  b.push_back('\x03');
  b.append(reinterpret_cast<const char*>(f), sizeof f);
  writeText(path("bin.ply"), b);
  expectBadInput("mesh bin.ply -o out.json", {"bin.ply: face 0 (binary data)", "'4294967295'", "out of range"},
                 {"bad.obj", "bin.ply"});
}

TEST_F(MeshInputCli, HugeDeclaredCountsAreRejectedAtOnce) {
  // 1e18 entries without properties: used to loop for ever.
  writeText(path("empty.ply"),
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000000000\nend_header\n");
  expectBadInput("mesh empty.ply -o out.json", {"empty.ply: line 3", "1000000000000000000"}, {"empty.ply"});
  writeText(path("ascii.ply"),
            "ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\nproperty float z\n"
            "end_header\n0 0 0\n");
  expectBadInput("mesh ascii.ply -o out.json", {"ascii.ply: line 3", "2000000000", "more than the remaining"},
                 {"ascii.ply", "empty.ply"});
  writeText(path("big.off"), "OFF\n1000000000000000000 1 0\n0 0 0\n");
  expectBadInput("mesh big.off -o out.json", {"big.off: line 2", "more than the file"},
                 {"ascii.ply", "big.off", "empty.ply"});
}

TEST_F(MeshInputCli, SlashFormsAndRelativeIndicesStillMesh) {
  // The example sphere, its faces rewritten as v/vt/vn, v//vn and negative indices.
  const std::string sphere = readText(kSourceDir + "/examples/surfaces/sphere.obj");
  ASSERT_FALSE(sphere.empty());
  std::istringstream in(sphere);
  std::string out = "vt 0 0\nvn 0 0 1\n", line;
  int nv = 0, k = 0;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      ++nv;
      out += line + "\n";
    } else if (tag == "f") {
      int a, b, c;
      ls >> a >> b >> c;
      if (k++ % 2 == 0)
        out += "f " + std::to_string(a) + "/1/1 " + std::to_string(b) + "//1 " + std::to_string(c) + "/1\n";
      else
        out += "f " + std::to_string(a - nv - 1) + " " + std::to_string(b - nv - 1) + "/1 " + std::to_string(c) + "\n";
    }
  }
  writeText(path("forms.obj"), out);
  ASSERT_EQ(run("-q mesh forms.obj --cells 20 -o out.json"), 0) << err_;
  EXPECT_EQ(files(), (std::vector<std::string>{"forms.obj", "out.json"}));
}

TEST_F(MeshInputCli, NumericFlagsOfMeshAreValidated) {
  writeText(path("s.obj"), readText(kSourceDir + "/examples/surfaces/sphere.obj"));
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"--scale 1e999", {"--scale", "'1e999'", "not a finite number", "[1e-06, 1e+06]"}},  // used to abort
      {"--scale nan", {"--scale", "'nan'"}},
      {"--scale 0", {"--scale", "(got 0)"}},
      {"--scale 1e9", {"--scale", "1000000000"}},
      {"--refinement 2147483648", {"--refinement", "2147483648", "[1, 20]"}},  // used to run for minutes
      {"--refinement inf", {"--refinement", "'inf'", "[1, 20]"}},
      {"--cells 100000", {"--cells", "100000", "[2, 10000]"}},
      // Integers beyond int or not whole: the range, not CLI11's "Could not convert".
      {"--cells 2147483648", {"--cells", "'2147483648'", "[2, 10000]"}},
      {"--cells 1e3", {"--cells", "'1e3'", "[2, 10000]"}},
      {"--iterations 1000000", {"--iterations", "1000000", "[1, 1000]"}},
      {"--iterations 99999999999", {"--iterations", "'99999999999'", "[1, 1000]"}},
      {"--restarts 1000000", {"--restarts", "1000000", "[1, 20]"}},
      {"--restarts 1.5", {"--restarts", "'1.5'", "[1, 20]"}},
      {"--control-points -3", {"--control-points", "'-3'", "[2, 1000]"}},
      {"--dual --faces 1e9", {"--faces", "'1e9'", "[4, 1000000]"}},
      {"--tolerance -1", {"--tolerance", "-1"}},
      {"--merge 2", {"--merge", "2"}},
      {"--edge-length 1e-12", {"--edge-length", "1e-12", "rod vertices"}},
      {"--edge-length 1e999", {"--edge-length", "'1e999'"}},
      {"--young-modulus inf", {"--young-modulus", "'inf'"}},
      {"--poisson-ratio 0.7", {"--poisson-ratio", "0.7"}},
      {"--material-density -5", {"--material-density", "-5"}},
      {"--radius 1e999", {"--radius", "'1e999'"}},
      {"--radius-bounds 0.001 1e999", {"--radius-bounds", "'1e999'"}},
      {"--gravity 0 0 nan", {"--gravity", "'nan'"}},
      {"--fix-box 0 0 0 1 1 1e999", {"--fix-box", "'1e999'"}},
      // issue 23: "-inf" read as short flags, the flag never named.
      {"--fix-box -1 -inf abc 1e12 inf 0", {"--fix-box", "'-inf'"}},
      {"--fix-box 0 0 0 1 abc 1", {"--fix-box", "'abc'"}},
      {"--control-points 100000", {"--control-points", "100000"}},
      {"--dual --faces 100000000", {"--faces", "100000000"}},
  };
  for (const auto& [flags, fragments] : cases) {
    SCOPED_TRACE(flags);
    const int status = run("mesh s.obj -o out.json " + flags);
    ASSERT_NE(status, kTimedOut) << "timed out after " << kTimeoutSeconds << " s";
    EXPECT_EQ(status, 2) << err_;
    EXPECT_EQ(err_.rfind("rodmesh: error: ", 0), 0u) << err_;
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
    for (const std::string& f : fragments)
      EXPECT_NE(err_.find(f), std::string::npos) << "'" << f << "' not in " << err_;
    EXPECT_EQ(files(), std::vector<std::string>{"s.obj"}) << "something was written";
  }
  // The grid route shares the finiteness check.
  expectBadInput("mesh --grid hex --size 1e999 0.2 --cells 2 2 -o out.json", {"--size", "'1e999'"}, {"s.obj"});
  expectBadInput("mesh --grid hex --size 1e300 0.2 --cells 2 2 -o out.json", {"--size", "1e+300"}, {"s.obj"});
  expectBadInput("mesh --grid hex --size 1e-300 0.2 --cells 2 2 -o out.json", {"--size", "1e-300"}, {"s.obj"});
  expectBadInput("mesh --grid hex --size 0.2 0.2 --cells 2 2 --pull right inf 0 0 -o out.json", {"--pull", "'inf'"},
                 {"s.obj"});
  expectBadInput("mesh --grid hex --size 0.2 0.2 --cells 2147483648 2 -o out.json",
                 {"--cells", "'2147483648'", "two whole numbers NX NY >= 1"}, {"s.obj"});
  expectBadInput("mesh --grid hex --size 0.2 0.2 --cells 2 2 --rod-vertices 99999999999 -o out.json",
                 {"--rod-vertices", "'99999999999'", "[2, 2147483647]"}, {"s.obj"});
}

TEST_F(MeshInputCli, NumericFlagsOfExportAreValidatedAndTheGridIsBounded) {
  writeText(path("c.json"), readText(kSourceDir + "/tests/cli/cantilever.json"));
  ASSERT_EQ(run("-q simulate c.json -o c.h5"), 0) << err_;
  const std::vector<std::string> inputs = {"c.h5", "c.json"};
  // 1e-6 m used to run for an hour; now refused from an estimate, with a step to use.
  expectBadInput("export c.h5 -o c.stl --resolution 1e-6",
                 {"--resolution 1e-06 m would need about", "triangles", "use --resolution", "or coarser"}, inputs);
  expectBadInput("export c.h5 -o c.stl --resolution 1e999",
                 {"--resolution", "'1e999'", "not a finite number", "(0, 1] m"}, inputs);
  expectBadInput("export c.h5 -o c.stl --resolution nan", {"--resolution", "'nan'"}, inputs);
  expectBadInput("export c.h5 -o c.stl --resolution -0.001", {"--resolution", "-0.001"}, inputs);
  expectBadInput("export c.h5 -o c.stl --resolution 5", {"--resolution", "(got 5)"}, inputs);
  expectBadInput("export c.h5 -o c.stl --fillet inf", {"--fillet", "'inf'"}, inputs);
  expectBadInput("export c.h5 -o c.stl --fillet -1", {"--fillet", "-1"}, inputs);
  expectBadInput("export c.h5 -o c.stl --fillet 3", {"--fillet", "(got 3)"}, inputs);
  // The default export still works.
  ASSERT_EQ(run("-q export c.h5 -o c.stl"), 0) << err_;
  EXPECT_EQ(files(), (std::vector<std::string>{"c.h5", "c.json", "c.stl"}));
}

}  // namespace
}  // namespace rodmesh
