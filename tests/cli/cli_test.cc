// End-to-end tests of the rodmesh executable (contract §2) and of the archive
// it writes (contract §3). Each test runs the real binary in a fresh temporary
// directory.
#include "io/archive.hh"

#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <dirent.h>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

std::string readFile(const std::string& path) { return clitest::readText(path); }

void writeFile(const std::string& path, const std::string& text) { clitest::writeText(path, text); }

bool fileExists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

std::string quote(const std::string& s) { return clitest::shellQuote(s); }

std::vector<std::string> nonEmptyLines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

struct RunResult {
  int status = -1;  // exit status, or -1 if the process did not exit normally
  std::string out, err;
};

// A temporary working directory with helpers to run rodmesh inside it.
class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_cli_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    logDir_ = dir_ + ".log";
    ASSERT_EQ(mkdir(logDir_.c_str(), 0755), 0);
  }
  void TearDown() override {
    std::system(("rm -rf " + quote(dir_) + " " + quote(logDir_)).c_str());
  }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  // Copies tests/cli/NAME into the working directory; returns its text.
  std::string copySource(const std::string& name) {
    const std::string text = readFile(kSourceDir + "/tests/cli/" + name);
    EXPECT_FALSE(text.empty()) << "cannot read tests/cli/" << name;
    writeFile(path(name), text);
    return text;
  }

  // Runs `rodmesh ARGS` with the working directory as cwd; stdout and stderr
  // are captured in files outside it, so that they do not count as output.
  RunResult run(const std::string& args) {
    const std::string cmd = "cd " + quote(dir_) + " && " + quote(kExe) + " " + args + " >" + quote(logDir_ + "/out") +
                            " 2>" + quote(logDir_ + "/err");
    const int raw = std::system(cmd.c_str());
    RunResult r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = readFile(logDir_ + "/out");
    r.err = readFile(logDir_ + "/err");
    return r;
  }

  std::vector<std::string> files() const { return clitest::listFiles(dir_); }

  // Runs a command that must fail with status 2, write nothing, and print
  // exactly one error line on stderr. Returns that line.
  std::string expectBadInput(const std::string& args, const std::vector<std::string>& before) {
    const RunResult r = run(args);
    EXPECT_EQ(r.status, 2) << "stderr: " << r.err;
    EXPECT_EQ(files(), before) << "a failed run must not write (or leave) any file";
    const auto lines = nonEmptyLines(r.err);
    EXPECT_EQ(lines.size(), 1u) << "expected exactly one error line, got:\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    return lines.empty() ? "" : lines[0];
  }

  std::string dir_, logDir_;
};

// ---------------------------------------------------------------- simulate: success

TEST_F(CliTest, SimulateWritesTheContractArchive) {
  const std::string sceneText = copySource("cantilever.json");
  const RunResult r = run("simulate cantilever.json -o out.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"})) << "no temporary files left";

  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.format, "rodmesh-archive/1");
  EXPECT_FALSE(a.version.empty());
  EXPECT_EQ(a.command, "simulate");
  EXPECT_EQ(a.status, "converged");
  EXPECT_EQ(a.sceneJson, sceneText) << "/scene must be the input text, verbatim";

  // /model
  EXPECT_EQ(a.effects, "stretch,bend") << "planar scene without gravity or connections";
  EXPECT_EQ(a.nVertices, 6);
  EXPECT_EQ(a.nEdges, 5);
  EXPECT_EQ(a.nRods, 1);
  EXPECT_EQ(a.nConnections, 0);
  EXPECT_GT(a.dofsPerPose, 0);
  EXPECT_LE(a.dofsPerPose, 2 * 6) << "planar: at most two unknowns per vertex";

  // /rest, /design
  ASSERT_EQ(a.restPositions.rows(), 6);
  for (int v = 0; v < 6; ++v) {
    EXPECT_NEAR(a.restPositions(v, 0), 0.02 * v, 1e-15);
    EXPECT_EQ(a.restPositions(v, 1), 0.0);
    EXPECT_EQ(a.restPositions(v, 2), 0.0);
  }
  ASSERT_EQ(a.radii.rows(), 6);
  for (int v = 0; v < 6; ++v) {
    EXPECT_EQ(a.radii(v, 0), 0.002);
    EXPECT_EQ(a.radii(v, 1), 0.001);
  }
  EXPECT_FALSE(a.initialRadii.has_value()) << "initial_radii is for optimize only";
  EXPECT_FALSE(a.history.has_value()) << "history is for optimize only";

  // /poses, in scene order
  ASSERT_EQ(a.poses.size(), 2u);
  EXPECT_EQ(a.poses[0].name, "small");
  EXPECT_EQ(a.poses[1].name, "large");
  for (const ArchivePose& p : a.poses) {
    SCOPED_TRACE(p.name);
    ASSERT_EQ(p.positions.rows(), 6);
    EXPECT_TRUE(p.positions.allFinite());
    EXPECT_EQ(p.twist.size(), 0) << "twist is not simulated in a planar scene";
    EXPECT_GE(p.residualNorm, 0.0);
    EXPECT_LT(p.residualNorm, 1e-6 * (p.name == "small" ? 0.001 : 0.01)) << "converged means a small force residual";
    EXPECT_EQ(p.positions.row(0).norm(), 0.0) << "clamped vertex stays put";
    EXPECT_LT(p.positions(5, 1), 0.0) << "tip moves along the load";
    EXPECT_NEAR(p.positions.col(2).norm(), 0.0, 1e-12) << "in-plane load, in-plane motion";
  }
  EXPECT_LT(a.poses[1].positions(5, 1), a.poses[0].positions(5, 1)) << "larger load, larger deflection";

  // Target and its RMS error on the pose that has one.
  ASSERT_EQ(a.poses[0].target.rows(), 6);
  EXPECT_EQ(a.poses[0].target, a.restPositions);
  ASSERT_TRUE(a.poses[0].rmsError.has_value());
  const double rms = std::sqrt((a.poses[0].positions - a.poses[0].target).rowwise().squaredNorm().sum() / 6.0);
  EXPECT_NEAR(*a.poses[0].rmsError, rms, 1e-12 + 1e-9 * rms);
  EXPECT_EQ(a.poses[1].target.rows(), 0);
  EXPECT_FALSE(a.poses[1].rmsError.has_value()) << "rms_error only when a target is given";

  // Progress went to stderr, nothing to stdout.
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_FALSE(r.err.empty());
}

TEST_F(CliTest, SimulateWritesTwistWhenTwistIsSimulated) {
  copySource("bent_3d.json");
  const RunResult r = run("simulate bent_3d.json -o out.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.status, "converged");
  EXPECT_EQ(a.effects, "stretch,bend,twist");
  ASSERT_EQ(a.poses.size(), 1u);
  const ArchivePose& p = a.poses[0];
  EXPECT_EQ(p.name, "up");
  ASSERT_EQ(p.positions.rows(), 5);
  EXPECT_EQ(p.twist.size(), a.nEdges) << "one twist angle per edge";
  EXPECT_EQ(a.nEdges, 4);
  EXPECT_TRUE(p.twist.allFinite());
  EXPECT_GT(p.positions(4, 2), 0.0) << "tip moves along the +z load";
}

// cantilever.json with "effects" inserted and the large load replaced.
std::string withEffectsAndLoad(std::string text, const std::string& effects, const std::string& largeLoad) {
  text.insert(text.find("\"radius\""), "\"effects\": " + effects + ",\n  ");
  const std::string from = "[0, -0.01, 0]";
  text.replace(text.find(from), from.size(), "[0, " + largeLoad + ", 0]");
  return text;
}

TEST_F(CliTest, ExplicitTwistOnAPlanarSceneWritesTwistAndMatchesThePlanarModel) {
  // Load 0.005 N: below the lateral-torsional buckling load of this flat
  // (r_t = 2 r_n) cantilever, so the in-plane equilibrium is the stable one.
  const std::string base = copySource("cantilever.json");
  const std::string planar = withEffectsAndLoad(base, "[\"stretch\", \"bend\"]", "-0.005");
  const std::string full = withEffectsAndLoad(base, "[\"stretch\", \"bend\", \"twist\"]", "-0.005");
  writeFile(path("planar.json"), planar);
  writeFile(path("full.json"), full);
  ASSERT_EQ(run("simulate planar.json -o planar.h5 -q").status, 0);
  const RunResult r = run("simulate full.json -o full.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  const Archive a = readArchive(path("planar.h5"));
  const Archive b = readArchive(path("full.h5"));
  EXPECT_EQ(a.effects, "stretch,bend");
  EXPECT_EQ(b.effects, "stretch,bend,twist");
  EXPECT_EQ(b.sceneJson, full);
  EXPECT_LT(a.dofsPerPose, b.dofsPerPose) << "the planar model has fewer unknowns";
  ASSERT_EQ(a.poses.size(), 2u);
  ASSERT_EQ(b.poses.size(), 2u);
  for (int p = 0; p < 2; ++p) {
    SCOPED_TRACE(a.poses[p].name);
    EXPECT_EQ(a.poses[p].twist.size(), 0);
    ASSERT_EQ(b.poses[p].twist.size(), 5) << "one twist angle per edge";
    EXPECT_NEAR(b.poses[p].twist.cwiseAbs().maxCoeff(), 0.0, 1e-9) << "in-plane load: no twist";
    EXPECT_NEAR((a.poses[p].positions - b.poses[p].positions).cwiseAbs().maxCoeff(), 0.0, 1e-9)
        << "the planar and the full 3D model reach the same equilibrium";
  }
}

// DISABLED: fails at the time of writing (solver/newton.cc). The same flat
// cantilever under 0.5 N, about 75 times its lateral-torsional buckling load,
// converges in 14 Newton iterations with the planar model but not with twist
// enabled: the in-plane equilibrium is a saddle of the 3D energy, the Hessian
// is indefinite along it, and the diagonal shift proportional to |H_ii| needed
// to make it positive definite all but cancels the soft bending directions, so
// Newton stalls at a few percent of the load. Enable once the solver copes.
TEST_F(CliTest, FullModelConvergesBeyondLateralTorsionalBuckling) {
  const std::string base = copySource("cantilever.json");
  writeFile(path("full.json"), withEffectsAndLoad(base, "[\"stretch\", \"bend\", \"twist\"]", "-0.5"));
  const RunResult r = run("simulate full.json -o full.h5");
  EXPECT_EQ(r.status, 0) << r.err;
  if (r.status == 0 || r.status == 1) {
    const Archive b = readArchive(path("full.h5"));
    EXPECT_EQ(b.status, "converged");
    // The in-plane state is a saddle of the 3D energy at this load: the
    // solver must leave it for the laterally buckled, twisted equilibrium.
    const ArchivePose* large = nullptr;
    for (const ArchivePose& p : b.poses)
      if (p.name == "large") large = &p;
    ASSERT_NE(large, nullptr);
    EXPECT_GT(large->positions.col(2).cwiseAbs().maxCoeff(), 1e-3) << "no out-of-plane (lateral) deflection";
    EXPECT_GT(large->twist.cwiseAbs().maxCoeff(), 0.1) << "no twist: still at the in-plane saddle";
  }
}

// tests/cli/strip_roll180.json (a sweep case): a strip of 84 vertices
// clamped at one end, its other end (a handle of six vertices held at
// explicit positions) rolled by 120 and by 180 degrees. Ramping each
// held vertex on a straight line, the half turn made two handle vertices
// meet at load factor 1/2 (a zero-length edge: "energy or forces are not
// finite", exit 1); a rigidly moved handle now turns rigidly on the way.
TEST_F(CliTest, AHandleRolledHalfATurnIsLoadedAlongItsRotation) {
  copySource("strip_roll180.json");
  const RunResult r = run("simulate strip_roll180.json -o out.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.status, "converged");
  ASSERT_EQ(a.poses.size(), 2u);
  for (const ArchivePose& p : a.poses) {
    EXPECT_EQ(p.status, "converged") << p.name;
    EXPECT_EQ(p.stable, 1) << p.name;
    EXPECT_TRUE(p.positions.allFinite()) << p.name;
  }
}

TEST_F(CliTest, QuietPrintsNothingOnSuccess) {
  copySource("cantilever.json");
  for (const std::string args : {"--quiet simulate cantilever.json -o a.h5", "simulate cantilever.json -o b.h5 --quiet",
                                 "simulate -q cantilever.json -o c.h5"}) {
    SCOPED_TRACE(args);
    const RunResult r = run(args);
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.err, "");
    EXPECT_EQ(r.out, "");
  }
  EXPECT_EQ(files(), (std::vector<std::string>{"a.h5", "b.h5", "c.h5", "cantilever.json"}));
}

TEST_F(CliTest, UnknownSceneKeysWarnButSucceed) {
  std::string text = copySource("cantilever.json");
  text.insert(text.find("\"radius\""), "\"colour\": \"red\",\n  ");
  writeFile(path("cantilever.json"), text);
  const RunResult r = run("simulate cantilever.json -o out.h5");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("colour"), std::string::npos) << "the unknown key is reported:\n" << r.err;
  EXPECT_TRUE(fileExists(path("out.h5")));
}

TEST_F(CliTest, OverwritesAnExistingOutput) {
  copySource("cantilever.json");
  writeFile(path("out.h5"), "old contents");
  const RunResult r = run("simulate cantilever.json -o out.h5 -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(readArchive(path("out.h5")).status, "converged");
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));
}

// A load so small that the forces' round-off is a large part of it: the
// pose converges at the round-off floor, and its line says so next to a
// relative residual far above the tolerance; an ordinary load's line does
// not.
TEST_F(CliTest, APoseConvergedAtTheRoundOffFloorSaysSo) {
  std::string v;
  for (int i = 0; i < 6; ++i) v += (i ? ", [" : "[") + std::to_string(3.0 + 0.02 * i) + ", -2, 5]";
  writeFile(path("far.json"),
            "{\"format\": \"rodmesh-scene/1\", \"material\": {\"young_modulus\": 1e7, \"poisson_ratio\": 0.4, "
            "\"density\": 1000}, \"vertices\": [" + v + "], \"rods\": [{\"vertices\": [0, 1, 2, 3, 4, 5]}], "
            "\"radius\": [0.002, 0.001], \"poses\": ["
            "{\"name\": \"tiny\", \"clamped\": [{\"vertex\": 0}], \"forces\": [{\"vertex\": 5, \"force\": [0, 0, -1e-13]}]}, "
            "{\"name\": \"ordinary\", \"clamped\": [{\"vertex\": 0}], \"forces\": [{\"vertex\": 5, \"force\": [0, 0, -1e-3]}]}]}");
  const RunResult r = run("simulate far.json -o out.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string tiny, ordinary;
  for (const std::string& line : nonEmptyLines(r.err)) {
    if (line.find("pose 0 'tiny'") == 0) tiny = line;
    if (line.find("pose 1 'ordinary'") == 0) ordinary = line;
  }
  EXPECT_NE(tiny.find("converged"), std::string::npos) << r.err;
  EXPECT_NE(tiny.find("(at the round-off floor of the forces, "), std::string::npos) << r.err;
  ASSERT_FALSE(ordinary.empty()) << r.err;
  EXPECT_EQ(ordinary.find("round-off"), std::string::npos) << ordinary;
}

// ---------------------------------------------------------------- simulate: not converged

TEST_F(CliTest, NotConvergedExitsOneAndStillWritesTheArchive) {
  // One Newton iteration per load step cannot bring the large-deflection pose
  // (0.01 N on a 0.1 m cantilever) to a 1e-10 relative residual: from the
  // straight rod, the linearised step stretches the rod and the line search
  // cuts it, and load continuation gives up at its smallest step.
  copySource("cantilever.json");
  const RunResult r = run("simulate cantilever.json -o out.h5 --max-iter 1 --tol 1e-10");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));
  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.status, "not_converged");
  ASSERT_EQ(a.poses.size(), 2u);
  EXPECT_EQ(a.poses[1].name, "large");
  EXPECT_EQ(a.poses[1].status, "not_converged");
  EXPECT_GT(a.poses[1].residualNorm, 1e-10 * 0.01) << "the archive reports the residual actually reached";
  EXPECT_EQ(a.poses[1].positions.rows(), 6);
  EXPECT_TRUE(a.poses[1].positions.allFinite());
}

// ---------------------------------------------------------------- simulate: bad input

TEST_F(CliTest, BadSceneExitsTwoWithOneLineAndWritesNothing) {
  std::string text = copySource("cantilever.json");
  // Second clamped entry of pose 1 points past the 6 vertices.
  const std::string from = "\"clamped\": [ { \"vertex\": 0 } ],\n      \"forces\": [ { \"vertex\": 5, \"force\": [0, -0.01, 0]";
  const auto pos = text.find(from);
  ASSERT_NE(pos, std::string::npos);
  text.replace(pos, from.size(),
               "\"clamped\": [ { \"vertex\": 0 }, { \"vertex\": 17 } ],\n      \"forces\": [ { \"vertex\": 5, \"force\": [0, -0.01, 0]");
  writeFile(path("bad.json"), text);
  std::remove(path("cantilever.json").c_str());
  const std::string line = expectBadInput("simulate bad.json -o out.h5", {"bad.json"});
  EXPECT_NE(line.find("bad.json"), std::string::npos) << line;
  EXPECT_NE(line.find("poses[1].clamped[1].vertex"), std::string::npos) << line;
  EXPECT_NE(line.find("17"), std::string::npos) << line;
}

TEST_F(CliTest, ConnectionOfTooManyRodsExitsTwoNamingFileAndVertex) {
  // Seven rods end at vertex 0: beyond the connection model's six.
  std::string v = "[[0, 0, 0]", rods;
  for (int r = 0; r < 7; ++r) {
    const double a = 2 * 3.14159265358979 * r / 7;
    v += ", [" + std::to_string(0.01 * std::cos(a)) + ", " + std::to_string(0.01 * std::sin(a)) + ", 0]";
    rods += std::string(r ? ", " : "") + "{\"vertices\": [0, " + std::to_string(r + 1) + "]}";
  }
  writeFile(path("star.json"), "{\"format\": \"rodmesh-scene/1\", \"material\": {\"young_modulus\": 1e7, "
                               "\"poisson_ratio\": 0.4, \"density\": 1000}, \"vertices\": " + v + "], \"rods\": [" + rods +
                               "], \"radius\": [0.001, 0.001], \"poses\": [{\"fixed\": [{\"vertex\": 1}]}]}");
  const std::string line = expectBadInput("simulate star.json -o out.h5", {"star.json"});
  EXPECT_NE(line.find("star.json"), std::string::npos) << line;
  EXPECT_NE(line.find("vertex 0"), std::string::npos) << line;
  EXPECT_NE(line.find("7"), std::string::npos) << line;
}

TEST_F(CliTest, BadSceneLeavesAnExistingOutputUntouched) {
  writeFile(path("bad.json"), "{\"format\": \"rodmesh-scene/1\"}");
  writeFile(path("out.h5"), "previous result");
  const std::string line = expectBadInput("simulate bad.json -o out.h5", {"bad.json", "out.h5"});
  EXPECT_NE(line.find("bad.json"), std::string::npos) << line;
  EXPECT_NE(line.find("material"), std::string::npos) << line;
  EXPECT_EQ(readFile(path("out.h5")), "previous result");
}

TEST_F(CliTest, UnparseableSceneExitsTwo) {
  writeFile(path("broken.json"), "{\n  \"format\": \"rodmesh-scene/1\",\n  \"vertices\": [[0, 0, 0]\n");
  const std::string line = expectBadInput("simulate broken.json -o out.h5", {"broken.json"});
  EXPECT_NE(line.find("broken.json"), std::string::npos) << line;
  EXPECT_NE(line.find("line "), std::string::npos) << line;
}

TEST_F(CliTest, BadSceneStillReportedWhenQuiet) {
  writeFile(path("bad.json"), "[]");
  const std::string line = expectBadInput("--quiet simulate bad.json -o out.h5", {"bad.json"});
  EXPECT_NE(line.find("bad.json"), std::string::npos) << line;
}

TEST_F(CliTest, MissingSceneFileExitsTwo) {
  const std::string line = expectBadInput("simulate nowhere.json -o out.h5", {});
  EXPECT_NE(line.find("nowhere.json"), std::string::npos) << line;
}

TEST_F(CliTest, OutputInMissingDirectoryExitsTwo) {
  copySource("cantilever.json");
  const std::string line = expectBadInput("simulate cantilever.json -o no/such/dir/out.h5", {"cantilever.json"});
  EXPECT_NE(line.find("no/such/dir"), std::string::npos) << line;
}

TEST_F(CliTest, UnwritableOutputExitsTwoAndLeavesNoTemporaryFile) {
  // The output path is an existing directory: the solve succeeds, the final
  // rename fails, and no temporary file may remain.
  copySource("cantilever.json");
  ASSERT_EQ(mkdir(path("out.h5").c_str(), 0755), 0);
  writeFile(path("out.h5/keep"), "x");
  const RunResult r = run("simulate cantilever.json -o out.h5 -q");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(nonEmptyLines(r.err).size(), 1u) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));
}

TEST_F(CliTest, UsageErrorsExitTwoAndWriteNothing) {
  copySource("cantilever.json");
  const std::vector<std::string> before = {"cantilever.json"};
  for (const std::string args : {
           "simulate cantilever.json",                           // missing -o
           "simulate cantilever.json -o out.h5 --no-such-flag",  // unknown flag
           "simulate -o out.h5",                                 // missing scene
           "simulate cantilever.json -o out.h5 --max-iter many", // mistyped value
           "frobnicate cantilever.json -o out.h5",               // unknown verb
           "",                                                   // no verb
       }) {
    SCOPED_TRACE("rodmesh " + args);
    const RunResult r = run(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(r.err.empty() && r.out.empty()) << "a usage error must say something";
    EXPECT_EQ(files(), before);
  }
}

TEST_F(CliTest, InvalidSolverOptionsExitTwo) {
  copySource("cantilever.json");
  for (const std::string args : {"simulate cantilever.json -o out.h5 --max-iter 0",
                                 "simulate cantilever.json -o out.h5 --tol 0", "simulate cantilever.json -o out.h5 --tol 2",
                                 "simulate cantilever.json -o out.h5 --tol -1e-6"}) {
    SCOPED_TRACE(args);
    const RunResult r = run(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(nonEmptyLines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(files(), std::vector<std::string>{"cantilever.json"});
  }
}

TEST_F(CliTest, HelpAndVersionExitZero) {
  EXPECT_EQ(run("--help").status, 0);
  EXPECT_EQ(run("simulate --help").status, 0);
  const RunResult v = run("--version");
  EXPECT_EQ(v.status, 0);
  EXPECT_FALSE(v.out.empty());
}

// ---------------------------------------------------------------- inspect

TEST_F(CliTest, InspectSummarisesAnArchive) {
  copySource("cantilever.json");
  ASSERT_EQ(run("simulate cantilever.json -o out.h5 -q").status, 0);
  const RunResult r = run("inspect out.h5");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(r.out.empty());
  EXPECT_NE(r.out.find("small"), std::string::npos) << "pose names are listed:\n" << r.out;
  EXPECT_NE(r.out.find("large"), std::string::npos) << r.out;
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"})) << "inspect writes nothing";
}

TEST_F(CliTest, InspectRejectsANonArchive) {
  copySource("cantilever.json");
  const std::string line = expectBadInput("inspect cantilever.json", {"cantilever.json"});
  EXPECT_NE(line.find("cantilever.json"), std::string::npos) << line;
}

TEST_F(CliTest, InspectRejectsAMissingFile) {
  const std::string line = expectBadInput("inspect none.h5", {});
  EXPECT_NE(line.find("none.h5"), std::string::npos) << line;
}

// ---------------------------------------------------------------- third-party reader

// Checks the archive with h5py, as a script of a user would read it.
const char* kH5pyCheck = R"PY(
import sys
import h5py
import numpy as np

archive, scene_path, planar_twist = sys.argv[1], sys.argv[2], sys.argv[3] == "twist"
errors = []
def check(cond, what):
    if not cond:
        errors.append(what)

with open(scene_path, "rb") as f:
    scene_text = f.read().decode("utf-8")

with h5py.File(archive, "r") as f:
    for key in ("format", "version", "command", "status"):
        check(key in f.attrs, "missing root attribute " + key)
        check(isinstance(f.attrs.get(key), str), "root attribute %s reads as %r, not str" % (key, type(f.attrs.get(key))))
    check(f.attrs.get("format") == "rodmesh-archive/1", "format is %r" % f.attrs.get("format"))
    check(f.attrs.get("command") == "simulate", "command is %r" % f.attrs.get("command"))
    check(f.attrs.get("status") == "converged", "status is %r" % f.attrs.get("status"))

    check(isinstance(f.get("scene"), h5py.Dataset), "/scene is not a dataset")
    check(h5py.check_string_dtype(f["scene"].dtype) is not None, "/scene is not a string dataset")
    check(f["scene"].asstr()[()] == scene_text, "/scene differs from the input file")

    m = f["model"].attrs
    check(isinstance(m.get("effects"), str), "/model effects reads as %r" % type(m.get("effects")))
    for key in ("dofs_per_pose", "n_vertices", "n_edges", "n_rods", "n_connections"):
        check(key in m and np.issubdtype(np.asarray(m[key]).dtype, np.integer), "/model %s missing or not an integer" % key)
    V, E = int(m["n_vertices"]), int(m["n_edges"])

    def dataset(path, shape):
        d = f.get(path)
        check(isinstance(d, h5py.Dataset), path + " missing")
        if isinstance(d, h5py.Dataset):
            check(d.dtype == np.float64, "%s has dtype %s" % (path, d.dtype))
            check(d.shape == shape, "%s has shape %s, expected %s" % (path, d.shape, shape))

    dataset("rest/positions", (V, 3))
    dataset("design/radii", (V, 2))
    check("initial_radii" not in f["design"], "/design/initial_radii written by simulate")
    check("history" not in f, "/history written by simulate")
    names = list(f["poses"].keys())
    check(len(names) > 0, "no poses")
    for name in names:
        p = "poses/" + name
        dataset(p + "/positions", (V, 3))
        if planar_twist:
            dataset(p + "/twist", (E,))
        else:
            check("twist" not in f[p], p + "/twist written although twist is not simulated")
        r = f[p].attrs.get("residual_norm")
        check(r is not None and np.asarray(r).dtype == np.float64, p + " residual_norm missing or not float64")
        if "target" in f[p]:
            dataset(p + "/target", (V, 3))
            check("rms_error" in f[p].attrs, p + " has a target but no rms_error")

for e in errors:
    print(e)
sys.exit(1 if errors else 0)
)PY";

class H5pyTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    // scripts/install-deps.sh installs python3-h5py: its absence is a broken setup.
    ASSERT_EQ(std::system("/usr/bin/python3 -c 'import h5py, numpy' >/dev/null 2>&1"), 0)
        << "/usr/bin/python3 cannot import h5py and numpy (run scripts/install-deps.sh)";
  }
  // Runs the h5py check; returns its exit status and fills `report`.
  int checkWithH5py(const std::string& archive, const std::string& scene, bool twist, std::string& report) {
    writeFile(logDir_ + "/check.py", kH5pyCheck);
    const std::string cmd = "/usr/bin/python3 " + quote(logDir_ + "/check.py") + " " + quote(path(archive)) + " " +
                            quote(path(scene)) + " " + (twist ? "twist" : "no-twist") + " >" +
                            quote(logDir_ + "/py") + " 2>&1";
    const int raw = std::system(cmd.c_str());
    report = readFile(logDir_ + "/py");
    return (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
  }
};

TEST_F(H5pyTest, PlanarArchiveFollowsTheContract) {
  copySource("cantilever.json");
  ASSERT_EQ(run("simulate cantilever.json -o out.h5 -q").status, 0);
  std::string report;
  EXPECT_EQ(checkWithH5py("out.h5", "cantilever.json", false, report), 0) << report;
}

TEST_F(H5pyTest, ThreeDimensionalArchiveFollowsTheContract) {
  copySource("bent_3d.json");
  ASSERT_EQ(run("simulate bent_3d.json -o out.h5 -q").status, 0);
  std::string report;
  EXPECT_EQ(checkWithH5py("out.h5", "bent_3d.json", true, report), 0) << report;
}

}  // namespace
}  // namespace rodmesh
