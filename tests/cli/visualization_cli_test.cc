// Looking at results: `rodmesh export` to ParaView files (.vtp, .pvd, .xmf)
// and scripts/render.py. The files are read back with third-party readers
// (VTK's vtkXMLPolyDataReader, h5py, matplotlib's PNG reader) by
// tests/cli/vtk_check.py and tests/cli/render_check.py, and compared with
// the archive they came from.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "io/archive.hh"
#include "tests/cli/cli_util.hh"

namespace rodmesh {
namespace {

using clitest::readText;
using clitest::shellQuote;
using clitest::writeText;

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;
const std::string kPython = "/usr/bin/python3";

struct Outcome {
  int status = -1;
  std::string out, err;
};

int lineCount(const std::string& s) {
  int n = 0;
  bool inLine = false;
  for (char c : s) {
    if (c == '\n') {
      n += inLine;
      inLine = false;
    } else {
      inLine = true;
    }
  }
  return n + inLine;
}

class VisualizationCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_vis_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    logDir_ = dir_ + ".log";
    ASSERT_EQ(mkdir(logDir_.c_str(), 0755), 0);
  }
  void TearDown() override { std::system(("rm -rf " + shellQuote(dir_) + " " + shellQuote(logDir_)).c_str()); }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }
  std::vector<std::string> files() const { return clitest::listFiles(dir_); }

  // Runs a shell command in the working directory, output captured outside it.
  Outcome shell(const std::string& cmd) {
    const std::string full = "cd " + shellQuote(dir_) + " && " + cmd + " >" + shellQuote(logDir_ + "/out") + " 2>" +
                             shellQuote(logDir_ + "/err");
    const int raw = std::system(full.c_str());
    Outcome r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = readText(logDir_ + "/out");
    r.err = readText(logDir_ + "/err");
    return r;
  }
  Outcome rodmesh(const std::string& args) { return shell(shellQuote(kExe) + " " + args); }
  Outcome python(const std::string& script, const std::string& args) {
    return shell(kPython + " " + shellQuote(kSourceDir + "/" + script) + " " + args);
  }

  // vtk_check.py MODE ARGS must pass.
  void expectVtkCheck(const std::string& args) {
    const Outcome r = python("tests/cli/vtk_check.py", args);
    EXPECT_EQ(r.status, 0) << "vtk_check.py " << args << ":\n" << r.err << r.out;
  }
  // render_check.py must pass; returns its report line.
  std::string expectPicture(const std::string& png, int width, int height, const std::string& colours) {
    const Outcome r = python("tests/cli/render_check.py", shellQuote(png) + " " + std::to_string(width) + " " +
                                                              std::to_string(height) + " " + colours);
    EXPECT_EQ(r.status, 0) << png << " (" << colours << "):\n" << r.err << r.out;
    return r.out;
  }

  // Simulates tests/cli/cantilever.json (poses "small" with a target, "large"
  // without) into NAME; extra simulate flags in `flags`.
  void simulateCantilever(const std::string& name, const std::string& flags = "", const std::string& sceneText = "") {
    writeText(path("cantilever.json"),
              sceneText.empty() ? readText(kSourceDir + "/tests/cli/cantilever.json") : sceneText);
    const Outcome r = rodmesh("-q simulate cantilever.json -o " + name + " " + flags);
    ASSERT_EQ(r.status, 0) << r.err;
  }

  // A bad export: status 2, one line on stderr, nothing written.
  std::string expectBadExport(const std::string& args) {
    const std::vector<std::string> before = files();
    const Outcome r = rodmesh("export " + args);
    EXPECT_EQ(r.status, 2) << "export " << args << ": " << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_EQ(files(), before) << "export " << args << " must not write anything";
    return r.err;
  }

  void SetUpPythonOrFail() {
    // scripts/install-deps.sh installs these Debian packages: their absence is a broken setup.
    ASSERT_EQ(
        std::system((kPython + " -c 'import vtkmodules.vtkIOXML, h5py, numpy, matplotlib' >/dev/null 2>&1").c_str()), 0)
        << kPython << " cannot import vtk, h5py, numpy and matplotlib (run scripts/install-deps.sh)";
  }

  std::string dir_, logDir_;
};

// ---------------------------------------------------------------- .vtp / .pvd

TEST_F(VisualizationCliTest, VtpOfRestShapeAndPosesMatchesTheArchive) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  ASSERT_EQ(rodmesh("-q export c.h5 -o rest.vtp").status, 0);
  ASSERT_EQ(rodmesh("-q export c.h5 -o small.vtp --pose small").status, 0);
  ASSERT_EQ(rodmesh("-q export c.h5 -o large.vtp --pose large").status, 0);
  EXPECT_EQ(files(), (std::vector<std::string>{"c.h5", "cantilever.json", "large.vtp", "rest.vtp", "small.vtp"}))
      << "one file each, no temporary files left";
  expectVtkCheck("vtp c.h5 rest.vtp");
  expectVtkCheck("vtp c.h5 small.vtp small");  // with a target: `error` array
  expectVtkCheck("vtp c.h5 large.vtp large");  // without: none
  // The checker can fail: the pose file is not the rest shape.
  EXPECT_NE(python("tests/cli/vtk_check.py", "vtp c.h5 large.vtp").status, 0);
}

TEST_F(VisualizationCliTest, VtpOfANetworkWithConnectionsHasOnePolylinePerRod) {
  SetUpPythonOrFail();
  // examples/sheet.json: 71 rods meeting at 54 connections.
  writeText(path("sheet.json"), readText(kSourceDir + "/examples/sheet.json"));
  const Outcome s = rodmesh("-q simulate sheet.json -o sheet.h5");
  ASSERT_EQ(s.status, 0) << s.err;
  const Archive a = readArchive(path("sheet.h5"));
  ASSERT_EQ(a.nRods, 71);
  ASSERT_EQ(rodmesh("-q export sheet.h5 -o sheet.pvd --all-poses").status, 0);
  expectVtkCheck("poses sheet.h5 sheet.pvd");
}

TEST_F(VisualizationCliTest, AllPosesWritesACollectionOfTheRestShapeAndEveryPose) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  const Outcome r = rodmesh("export c.h5 -o view.pvd --all-poses");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"c.h5", "cantilever.json", "view.pvd", "view_large.vtp", "view_rest.vtp",
                                               "view_small.vtp"}));
  expectVtkCheck("poses c.h5 view.pvd");
  // OUT.vtp names the same collection.
  ASSERT_EQ(rodmesh("-q export c.h5 -o other.vtp --all-poses").status, 0);
  expectVtkCheck("poses c.h5 other.pvd");
}

TEST_F(VisualizationCliTest, AllPosesFileNamesAreSafeAndDistinct) {
  SetUpPythonOrFail();
  // A pose named "rest" and one with a space.
  std::string scene = readText(kSourceDir + "/tests/cli/cantilever.json");
  scene.replace(scene.find("\"small\""), 7, "\"rest\"");
  scene.replace(scene.find("\"large\""), 7, "\"tip load\"");
  simulateCantilever("c.h5", "", scene);
  ASSERT_EQ(rodmesh("-q export c.h5 -o v.pvd --all-poses").status, 0);
  EXPECT_EQ(files(), (std::vector<std::string>{"c.h5", "cantilever.json", "v.pvd", "v_rest.vtp", "v_rest_2.vtp",
                                               "v_tip_load.vtp"}));
  expectVtkCheck("poses c.h5 v.pvd");
}

TEST_F(VisualizationCliTest, PvdOfADynamicRunIsATimeSeriesOfItsFrames) {
  SetUpPythonOrFail();
  simulateCantilever("d.h5", "--dynamic --duration 0.05 --fps 100");
  const Archive a = readArchive(path("d.h5"));
  ASSERT_EQ(a.frames.size(), 2u);
  ASSERT_EQ(a.frames[0].positions.size(), 6u);
  ASSERT_EQ(rodmesh("-q export d.h5 -o small.pvd --pose small").status, 0);
  std::vector<std::string> expected = {"cantilever.json", "d.h5", "small.pvd"};
  for (int t = 0; t < 6; ++t) expected.push_back("small_000" + std::to_string(t) + ".vtp");
  EXPECT_EQ(files(), expected);
  expectVtkCheck("frames d.h5 small.pvd small");
  // The checker can fail: these are not the frames of the other pose.
  EXPECT_NE(python("tests/cli/vtk_check.py", "frames d.h5 small.pvd large").status, 0);
  // Two poses have frames: --pose is needed.
  const std::string msg = expectBadExport("d.h5 -o any.pvd");
  EXPECT_NE(msg.find("--pose"), std::string::npos) << msg;
  // A static archive has no frames.
  simulateCantilever("s.h5");
  expectBadExport("s.h5 -o any.pvd --pose small");
}

// ---------------------------------------------------------------- XDMF

TEST_F(VisualizationCliTest, XdmfNextToTheArchiveReferencesItsDatasets) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  ASSERT_EQ(rodmesh("-q export c.h5 --xdmf").status, 0);
  EXPECT_EQ(files(), (std::vector<std::string>{"c.h5", "c.xmf", "cantilever.json"}));
  expectVtkCheck("xdmf c.h5 c.xmf");
  // In another directory the reference is relative to the .xmf.
  ASSERT_EQ(mkdir(path("views").c_str(), 0755), 0);
  ASSERT_EQ(rodmesh("-q export c.h5 -o views/c.xmf").status, 0);
  expectVtkCheck("xdmf c.h5 views/c.xmf");
}

TEST_F(VisualizationCliTest, XdmfOfADynamicPoseHoldsItsFrames) {
  SetUpPythonOrFail();
  simulateCantilever("d.h5", "--dynamic --duration 0.05 --fps 100");
  ASSERT_EQ(rodmesh("-q export d.h5 --xdmf --pose large -o large.xmf").status, 0);
  expectVtkCheck("xdmf d.h5 large.xmf large");
  EXPECT_NE(python("tests/cli/vtk_check.py", "xdmf d.h5 large.xmf small").status, 0) << "the checker can fail";
  ASSERT_EQ(rodmesh("-q export d.h5 --xdmf").status, 0);
  expectVtkCheck("xdmf d.h5 d.xmf");
}

// ---------------------------------------------------------------- bad input

TEST_F(VisualizationCliTest, BadExportsExitTwoWithOneMessageAndWriteNothing) {
  simulateCantilever("c.h5");
  writeText(path("keep.vtp"), "previous contents");
  writeText(path("text.h5"), "not an archive");

  std::string msg = expectBadExport("c.h5 -o keep.vtp --pose nope");
  EXPECT_NE(msg.find("nope"), std::string::npos) << msg;
  EXPECT_NE(msg.find("small"), std::string::npos) << "lists the available poses: " << msg;
  EXPECT_EQ(readText(path("keep.vtp")), "previous contents");

  msg = expectBadExport("text.h5 -o out.vtp");
  EXPECT_NE(msg.find("text.h5"), std::string::npos) << msg;
  expectBadExport("missing.h5 -o out.vtp");
  expectBadExport("text.h5 --xdmf");
  expectBadExport("text.h5 -o all.pvd --all-poses");

  msg = expectBadExport("c.h5 -o no/such/dir/out.vtp");
  EXPECT_NE(msg.find("no/such/dir"), std::string::npos) << msg;
  expectBadExport("c.h5 -o no/such/dir/out.pvd --all-poses");
  expectBadExport("c.h5 -o no/such/dir/out.xmf");
  expectBadExport("c.h5 -o out.pvd --all-poses --pose small");
  expectBadExport("c.h5 -o out.vtp --xdmf");
  expectBadExport("c.h5 -o out.txt --all-poses");
  expectBadExport("c.h5 --all-poses");
  expectBadExport("c.h5");  // -o is needed unless --xdmf
  ASSERT_EQ(mkdir(path("adir.vtp").c_str(), 0755), 0);
  expectBadExport("c.h5 -o adir.vtp");
}

// ---------------------------------------------------------------- scripts/render.py

// The archive of tests/cli/cantilever.json, as optimize would leave it: an
// initial design whose equilibria differ from the final ones, and radii that vary.
void makeOptimizedLooking(const std::string& from, const std::string& to) {
  Archive a = readArchive(from);
  for (ArchivePose& p : a.poses) {
    p.initialPositions = p.positions;
    p.initialPositions.col(1).array() += 0.01;
  }
  for (int v = 0; v < a.radii.rows(); ++v) a.radii(v, 1) = 0.001 + 0.0002 * v;
  writeArchive(a, to);
}

TEST_F(VisualizationCliTest, RenderDrawsTargetsFinalPositionsAndRadii) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  // Every pose and the radius panel: three 400-pixel panels.
  Outcome r = python("scripts/render.py", "c.h5 -o all.png");
  ASSERT_EQ(r.status, 0) << r.err;
  expectPicture("all.png", 1200, 400, "grey=yes red=no green=yes radius=yes");
  // A pose without a target: no grey.
  for (const std::string view : {"iso", "top", "front", "side"}) {
    r = python("scripts/render.py", "c.h5 -o large_" + view + ".png --pose large --view " + view);
    ASSERT_EQ(r.status, 0) << r.err;
    expectPicture("large_" + view + ".png", 800, 400, "grey=no red=no green=yes radius=yes");
  }
  // The checker can fail: a picture without a target has no grey.
  EXPECT_NE(python("tests/cli/render_check.py", "large_iso.png 800 400 grey=yes").status, 0);
  EXPECT_NE(python("tests/cli/render_check.py", "large_iso.png 1200 400").status, 0) << "wrong size";
}

TEST_F(VisualizationCliTest, RenderDrawsTheInitialDesignInRed) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  makeOptimizedLooking(path("c.h5"), path("o.h5"));
  Outcome r = python("scripts/render.py", "o.h5 -o small.png --pose small --view top");
  ASSERT_EQ(r.status, 0) << r.err;
  expectPicture("small.png", 800, 400, "grey=yes red=yes green=yes radius=yes");
  r = python("scripts/render.py", "o.h5 -o big.png --dpi 50 --panel-size 6");
  ASSERT_EQ(r.status, 0) << r.err;
  expectPicture("big.png", 900, 300, "");
}

// A real optimize archive (the README's picture): initial design, target,
// final positions and radii that vary; its .vtp files match it too.
TEST_F(VisualizationCliTest, RenderAndExportOfAnOptimizeArchive) {
  SetUpPythonOrFail();
  writeText(path("small.json"), readText(kSourceDir + "/tests/cli/optimize_small.json"));
  const Outcome o = rodmesh("-q optimize small.json -o small.h5 --method reduced --max-iter 60");
  ASSERT_TRUE(o.status == 0 || o.status == 1) << o.err;  // 1: stopped at --max-iter, archive written
  const Archive a = readArchive(path("small.h5"));
  ASSERT_EQ(a.poses.size(), 2u);
  ASSERT_EQ(a.poses[0].initialPositions.rows(), a.nVertices);
  ASSERT_GT(a.radii.maxCoeff() - a.radii.minCoeff(), 1e-4) << "optimized radii vary";
  const Outcome r = python("scripts/render.py", "small.h5 -o small.png");
  ASSERT_EQ(r.status, 0) << r.err;
  expectPicture("small.png", 1200, 400, "grey=yes red=yes green=yes radius=yes");
  ASSERT_EQ(rodmesh("-q export small.h5 -o small.pvd --all-poses").status, 0);
  expectVtkCheck("poses small.h5 small.pvd");
  ASSERT_EQ(rodmesh("-q export small.h5 --xdmf").status, 0);
  expectVtkCheck("xdmf small.h5 small.xmf");
}

TEST_F(VisualizationCliTest, RenderOfTheCantileverExample) {
  SetUpPythonOrFail();
  writeText(path("cantilever.json"), readText(kSourceDir + "/examples/cantilever.json"));
  ASSERT_EQ(rodmesh("-q simulate cantilever.json -o c.h5").status, 0);
  const Outcome r = python("scripts/render.py", "c.h5 -o c.png --view front");
  ASSERT_EQ(r.status, 0) << r.err;
  expectPicture("c.png", 1600, 400, "grey=no red=no green=yes radius=yes");  // three poses, no targets
}

TEST_F(VisualizationCliTest, RenderRejectsBadInputAndWritesNothing) {
  SetUpPythonOrFail();
  simulateCantilever("c.h5");
  writeText(path("text.h5"), "not an archive");
  const std::vector<std::string> before = files();
  for (const std::string args : {"c.h5 -o x.png --pose nope", "text.h5 -o x.png", "missing.h5 -o x.png",
                                 "c.h5 -o no/dir/x.png", "c.h5 -o x.jpg", "c.h5 -o x.png --view below"}) {
    SCOPED_TRACE(args);
    const Outcome r = python("scripts/render.py", args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(r.err.empty());
    EXPECT_EQ(files(), before);
  }
}

}  // namespace
}  // namespace rodmesh
